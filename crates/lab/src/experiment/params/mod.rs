//! Typed study parameters: how the values a manifest gives a run become
//! a study's own struct, and the parameter types several studies share.
//!
//! A study declares its parameters as a struct deriving
//! `serde::Deserialize` with `#[serde(deny_unknown_fields)]`, registers it
//! with `typed_params!` (which ties it to its one-line docs), and gets a
//! [`Params`] implementation: [`Params::names`] comes from the struct's
//! own field list (so the manifest's check for misspelt parameters cannot
//! drift from what the study reads) and [`Params::from_run`] deserializes
//! one run's values. A study that reads two groups (the rendering
//! parameters of [`render::RenderParams`] and its own) uses the pair
//! `(A, B)`.
//!
//! Every failure is a [`RunParamError`] naming the parameter, which the
//! manifest turns into an error at the line where the value is written.
//! Values of these types are parsed from strings by [`FromParam`] (via
//! [`parsed`] and [`parsed_opt`]); [`InRange`] is an integer checked
//! against bounds; [`Resolution`] is "WxH".

pub mod de;
pub mod render;

use crate::experiment::sweep::{RunParam, RunPoint};
use raylab::accel::AccelKind;
use raylab::film::Filter;
use raylab::integrator::IntegratorKind;
use raylab::sampler::Sampler;
use serde::de::{Deserializer, Visitor};
use serde::Deserialize;
use std::fmt;
use std::path::{Path, PathBuf};

/// A parameter a study reads, with its one-line documentation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamDoc {
    /// The name used in `[fixed]` and `[[sweep]]` blocks.
    pub name: &'static str,
    /// What it means and what values it takes.
    pub doc: &'static str,
}

/// A run's parameters are wrong: which one (if one) and why. The manifest
/// turns it into an error naming the file, the line and the parameter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RunParamError {
    /// The offending parameter, when the problem is one parameter.
    pub param: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl RunParamError {
    /// A problem with parameter `name`.
    pub fn new(name: &str, message: impl std::fmt::Display) -> Self {
        Self {
            param: Some(name.to_string()),
            message: message.to_string(),
        }
    }

    /// A problem with the run as a whole (a missing or conflicting
    /// parameter).
    pub fn run(message: impl std::fmt::Display) -> Self {
        Self {
            param: None,
            message: message.to_string(),
        }
    }

    /// The same error, blamed on `name` unless it already names a
    /// parameter.
    pub fn of_param(mut self, name: &str) -> Self {
        self.param.get_or_insert_with(|| name.to_string());
        self
    }
}

impl fmt::Display for RunParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.param {
            Some(p) => write!(f, "parameter `{p}`: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for RunParamError {}

/// What a type expects, in the words of the manifest: serde names Rust's
/// types (`u32`, `f64`), a manifest writer thinks in integers and numbers.
fn expected(exp: &dyn serde::de::Expected) -> String {
    let s = exp.to_string();
    match s.as_str() {
        "u8" | "u16" | "u32" | "u64" | "u128" | "usize" => "a non-negative integer".into(),
        "i8" | "i16" | "i32" | "i64" | "i128" | "isize" => "an integer".into(),
        "f32" | "f64" => "a number".into(),
        "a borrowed string" => "a string".into(),
        _ => s,
    }
}

/// `a`, `b` as "`a`, `b`".
pub(crate) fn quoted<'a>(names: impl IntoIterator<Item = &'a str>) -> String {
    names
        .into_iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl serde::de::Error for RunParamError {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Self::run(msg.to_string())
    }

    fn invalid_type(unexp: serde::de::Unexpected<'_>, exp: &dyn serde::de::Expected) -> Self {
        Self::run(format!("must be {}, got {unexp}", expected(exp)))
    }

    fn invalid_value(unexp: serde::de::Unexpected<'_>, exp: &dyn serde::de::Expected) -> Self {
        Self::run(format!("must be {}, got {unexp}", expected(exp)))
    }

    fn unknown_variant(variant: &str, expected: &'static [&'static str]) -> Self {
        Self::run(format!(
            "`{variant}`: expected {}",
            quoted(expected.iter().copied())
        ))
    }

    fn unknown_field(field: &str, expected: &'static [&'static str]) -> Self {
        Self::new(
            field,
            format!(
                "unknown parameter (known: {})",
                quoted(expected.iter().copied())
            ),
        )
    }

    fn missing_field(field: &'static str) -> Self {
        Self::run(format!(
            "`{field}` is required (in [fixed] or in the sweep)"
        ))
    }
}

/// A study's typed parameters.
///
/// Implemented by `typed_params!` for a `Deserialize` struct, and by
/// pairs `(A, B)` for a study that reads two groups.
pub trait Params: Sized {
    /// Every parameter, documented, in the order `--help` lists them.
    fn docs() -> Vec<ParamDoc>;

    /// The names of the parameters: the fields of the struct(s).
    fn names() -> Vec<&'static str>;

    /// Read these parameters (each one of [`Params::names`]).
    fn from_params(params: &[&RunParam]) -> Result<Self, RunParamError>;

    /// Read the parameters of a run. Parameters the study does not read
    /// are left out: the manifest allows them only as helpers that a
    /// `{name}` template uses, and rejects the others when it is loaded.
    fn from_run(run: &RunPoint) -> Result<Self, RunParamError> {
        let names = Self::names();
        let mine: Vec<&RunParam> = run
            .params
            .iter()
            .filter(|p| names.contains(&p.name.as_str()))
            .collect();
        Self::from_params(&mine)
    }
}

/// Implement [`Params`] for a struct deriving `Deserialize` (with
/// `#[serde(deny_unknown_fields)]`), documented by `$docs: &[ParamDoc]`,
/// one entry per field (a unit test of the registry checks that they
/// match).
macro_rules! typed_params {
    ($t:ty, $docs:expr) => {
        impl $crate::experiment::params::Params for $t {
            fn docs() -> Vec<$crate::experiment::params::ParamDoc> {
                $docs.to_vec()
            }

            fn names() -> Vec<&'static str> {
                $crate::experiment::params::de::field_names::<$t>().to_vec()
            }

            fn from_params(
                params: &[&$crate::experiment::sweep::RunParam],
            ) -> Result<Self, $crate::experiment::params::RunParamError> {
                $crate::experiment::params::de::from_params(params)
            }
        }
    };
}
pub(crate) use typed_params;

impl<A: Params, B: Params> Params for (A, B) {
    fn docs() -> Vec<ParamDoc> {
        let mut d = A::docs();
        d.extend(B::docs());
        d
    }

    fn names() -> Vec<&'static str> {
        let mut n = A::names();
        n.extend(B::names());
        n
    }

    fn from_params(params: &[&RunParam]) -> Result<Self, RunParamError> {
        let (a, b) = (A::names(), B::names());
        if let Some(p) = params
            .iter()
            .find(|p| !a.contains(&p.name.as_str()) && !b.contains(&p.name.as_str()))
        {
            return Err(RunParamError::new(
                &p.name,
                format!("unknown parameter (known: {})", quoted(Self::names())),
            ));
        }
        let of = |names: &[&str]| -> Vec<&RunParam> {
            params
                .iter()
                .filter(|p| names.contains(&p.name.as_str()))
                .copied()
                .collect()
        };
        Ok((A::from_params(&of(&a))?, B::from_params(&of(&b))?))
    }
}

/// A value written as a string and parsed by its own parser (sampler and
/// accelerator names, "WxH", …), whose error becomes the message: a
/// [`RunParamError`] of the run as a whole, which the deserializer blames on
/// the parameter being read.
pub trait FromParam: Sized {
    /// Parse the string a manifest gives.
    fn from_param(s: &str) -> Result<Self, RunParamError>;
}

impl FromParam for Sampler {
    fn from_param(s: &str) -> Result<Self, RunParamError> {
        Sampler::parse(s).map_err(RunParamError::run)
    }
}

impl FromParam for Filter {
    fn from_param(s: &str) -> Result<Self, RunParamError> {
        Filter::parse(s).map_err(RunParamError::run)
    }
}

impl FromParam for AccelKind {
    fn from_param(s: &str) -> Result<Self, RunParamError> {
        s.parse::<AccelKind>()
            .map_err(|e| RunParamError::run(e.to_string()))
    }
}

impl FromParam for IntegratorKind {
    fn from_param(s: &str) -> Result<Self, RunParamError> {
        IntegratorKind::parse(s).map_err(RunParamError::run)
    }
}

#[cfg(feature = "embree")]
impl FromParam for raylab::accel::EmbreeConfig {
    fn from_param(s: &str) -> Result<Self, RunParamError> {
        s.parse::<Self>()
            .map_err(|e| RunParamError::run(e.to_string()))
    }
}

struct ParseVisitor<T>(std::marker::PhantomData<T>);

impl<T: FromParam> Visitor<'_> for ParseVisitor<T> {
    type Value = T;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a string")
    }

    fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<T, E> {
        T::from_param(s).map_err(E::custom)
    }
}

/// `deserialize_with` for a [`FromParam`] field.
pub fn parsed<'de, D: Deserializer<'de>, T: FromParam>(d: D) -> Result<T, D::Error> {
    d.deserialize_str(ParseVisitor(std::marker::PhantomData))
}

/// `deserialize_with` for an optional [`FromParam`] field (with
/// `#[serde(default)]`: absent is `None`).
pub fn parsed_opt<'de, D: Deserializer<'de>, T: FromParam>(d: D) -> Result<Option<T>, D::Error> {
    parsed(d).map(Some)
}

/// `value`, or else the parameter's default as a manifest would spell it
/// (`"bvh"`, `"embree:high+robust"`), parsed like a written value.
pub fn or_default<T: FromParam>(
    value: Option<T>,
    name: &str,
    default: &str,
) -> Result<T, RunParamError> {
    match value {
        Some(v) => Ok(v),
        None => T::from_param(default).map_err(|e| e.of_param(name)),
    }
}

/// An integer parameter in `LO..=HI`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct InRange<const LO: i64, const HI: i64>(i64);

impl<const LO: i64, const HI: i64> InRange<LO, HI> {
    /// The value.
    pub fn get(self) -> i64 {
        self.0
    }
}

impl<'de, const LO: i64, const HI: i64> Deserialize<'de> for InRange<LO, HI> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const LO: i64, const HI: i64>;
        impl<const LO: i64, const HI: i64> Visitor<'_> for V<LO, HI> {
            type Value = InRange<LO, HI>;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "an integer in {LO}..={HI}")
            }

            fn visit_i64<E: serde::de::Error>(self, i: i64) -> Result<Self::Value, E> {
                if (LO..=HI).contains(&i) {
                    Ok(InRange(i))
                } else {
                    Err(E::custom(format!("must be in {LO}..={HI}, got {i}")))
                }
            }

            fn visit_u64<E: serde::de::Error>(self, u: u64) -> Result<Self::Value, E> {
                match i64::try_from(u) {
                    Ok(i) => self.visit_i64(i),
                    Err(_) => Err(E::custom(format!("must be in {LO}..={HI}, got {u}"))),
                }
            }
        }
        d.deserialize_i64(V::<LO, HI>)
    }
}

/// The largest image side accepted (a typo guard, not a renderer limit).
pub const MAX_SIDE: u32 = 65_536;

/// An image size, written "WxH" (or "W×H"), each side in 1..=[`MAX_SIDE`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Resolution {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl Resolution {
    /// Parse "WxH" (or "W×H"); `None` unless both sides are in
    /// 1..=[`MAX_SIDE`].
    pub fn parse(s: &str) -> Option<Resolution> {
        let (w, h) = s.split_once('x').or_else(|| s.split_once('×'))?;
        let (width, height) = (w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?);
        let ok = |v: u32| (1..=MAX_SIDE).contains(&v);
        (ok(width) && ok(height)).then_some(Resolution { width, height })
    }
}

impl FromParam for Resolution {
    fn from_param(s: &str) -> Result<Self, RunParamError> {
        Resolution::parse(s).ok_or_else(|| {
            RunParamError::run(format!("`{s}` is not \"WxH\" with sides in 1..={MAX_SIDE}"))
        })
    }
}

/// `rel`, a file named by parameter `name`, resolved against the
/// manifest's folder and checked to exist (`what` says what kind of file
/// it should be, for the message).
pub fn existing_file(
    base_dir: &Path,
    name: &str,
    rel: &str,
    what: &str,
) -> Result<PathBuf, RunParamError> {
    let path = base_dir.join(rel);
    if path.is_file() {
        Ok(path)
    } else {
        Err(RunParamError::new(
            name,
            format!("{}: no such {what} file", path.display()),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::sweep::Value;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct A {
        #[serde(deserialize_with = "parsed")]
        size: Resolution,
        #[serde(default)]
        depth: Option<InRange<0, 10>>,
    }
    typed_params!(
        A,
        [
            ParamDoc {
                name: "size",
                doc: "WxH"
            },
            ParamDoc {
                name: "depth",
                doc: "0 to 10"
            }
        ]
    );

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct B {
        #[serde(default, deserialize_with = "parsed_opt")]
        sampler: Option<Sampler>,
    }
    typed_params!(
        B,
        [ParamDoc {
            name: "sampler",
            doc: "a sampler"
        }]
    );

    fn run(params: &[(&str, Value)]) -> RunPoint {
        RunPoint {
            sweep: "s".into(),
            params: params
                .iter()
                .map(|(n, v)| RunParam {
                    name: n.to_string(),
                    value: v.clone(),
                    span: 0..0,
                })
                .collect(),
        }
    }

    #[test]
    fn resolutions_parse_with_x_or_times() {
        let r = |w, h| {
            Some(Resolution {
                width: w,
                height: h,
            })
        };
        assert_eq!(Resolution::parse("800x600"), r(800, 600));
        assert_eq!(Resolution::parse("325×243"), r(325, 243));
        assert_eq!(Resolution::parse("0x5"), None);
        assert_eq!(Resolution::parse("800"), None);
        assert_eq!(Resolution::parse("99999x1"), None);
    }

    #[test]
    fn pairs_split_their_parameters() {
        assert_eq!(<(A, B)>::names(), ["size", "depth", "sampler"]);
        assert_eq!(<(A, B)>::docs().len(), 3);
        let (a, b) = <(A, B)>::from_run(&run(&[
            ("sampler", Value::Str("ogss:2".into())),
            ("size", Value::Str("4x3".into())),
            ("helper", Value::Int(1)),
        ]))
        .unwrap();
        assert_eq!((a.size.width, a.size.height, a.depth), (4, 3, None));
        assert!(b.sampler.is_some());
        let p = |name: &str, value| RunParam {
            name: name.into(),
            value,
            span: 0..0,
        };
        let e =
            <(A, B)>::from_params(&[&p("size", Value::Str("1x1".into())), &p("x", Value::Int(1))])
                .unwrap_err();
        assert_eq!(e.param.as_deref(), Some("x"));
        assert!(e.message.contains("`sampler`"), "{e}");
    }

    #[test]
    fn values_are_checked_and_errors_name_the_parameter() {
        let err = |params: &[(&str, Value)]| A::from_run(&run(params)).unwrap_err();
        let e = err(&[("size", Value::Str("4by3".into()))]);
        assert_eq!(e.param.as_deref(), Some("size"));
        assert!(e.message.contains("`4by3` is not \"WxH\""), "{e}");
        let e = err(&[
            ("size", Value::Str("4x3".into())),
            ("depth", Value::Int(11)),
        ]);
        assert_eq!(
            e.to_string(),
            "parameter `depth`: must be in 0..=10, got 11"
        );
        let e = err(&[
            ("size", Value::Str("4x3".into())),
            ("depth", Value::Str("deep".into())),
        ]);
        assert!(e.message.contains("must be an integer in 0..=10"), "{e}");
        let e = err(&[("depth", Value::Int(1))]);
        assert_eq!(
            (e.param, e.message.contains("`size` is required")),
            (None, true)
        );
        let e = B::from_run(&run(&[("sampler", Value::Str("ogss:0".into()))])).unwrap_err();
        assert_eq!(e.param.as_deref(), Some("sampler"));
    }
}
