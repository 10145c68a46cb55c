//! Parameter values and how a sweep expands into runs.
//!
//! A manifest gives each parameter either one value (`sampler = "centre"`),
//! a list (`sampler = ["centre", "ogss:2"]`) or a range
//! (`{ from = 1, to = 20, step = 1 }` or `{ from = 0.0, to = 1.0, count = 5 }`).
//! [`expand_values`] turns any of these into a list of [`Value`]s; the
//! cartesian product of the lists of one sweep gives its runs
//! ([`RunPoint`]), the first parameter varying slowest. String values may
//! name other parameters of the same run as `{name}` or `{name:0W}` (zero
//! padded to W digits), so a run can build a file name from a swept index:
//! `scene = "s1-{scene_index:02}.toml"`.

use serde::Serialize;
use std::fmt;
use std::ops::Range;

/// Most values one parameter may expand to: a guard against a slip such as
/// `step = 1e-9` that would otherwise allocate without bound.
pub const MAX_VALUES: usize = 100_000;

/// Most runs one sweep may have (the product of its list lengths), and
/// a manifest's sweeps in all: a plan of a million runs takes a few
/// hundred megabytes, and no experiment a person reads needs more.
pub const MAX_RUNS: usize = 1_000_000;

/// A parameter value, range or string template written wrongly: what is
/// wrong, in the manifest's terms. The manifest reader prefixes the file,
/// the line and the parameter.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ValueError(pub String);

/// A sweep that cannot be expanded into runs: what is wrong, and the byte
/// range of the manifest text it concerns (for the line in the message).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct SweepError {
    /// Byte range of the sweep or parameter in the manifest text.
    pub span: Range<usize>,
    /// What is wrong.
    pub message: String,
}

/// One parameter value: what a manifest may write on the right of `=`.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Value {
    /// An integer.
    Int(i64),
    /// A floating-point number.
    Float(f64),
    /// `true` or `false`.
    Bool(bool),
    /// A string (file names, sampler and accelerator names, "WxH").
    Str(String),
}

impl fmt::Display for Value {
    /// The form written to `data.csv` and used in run keys: integers and
    /// booleans as usual, floats in Rust's shortest round-trip form, strings
    /// as they are.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Int(i) => write!(f, "{i}"),
            Value::Float(x) => write!(f, "{x}"),
            Value::Bool(b) => write!(f, "{b}"),
            Value::Str(s) => f.write_str(s),
        }
    }
}

impl Value {
    /// The value as a number (integers and floats).
    pub fn as_f64(&self) -> Option<f64> {
        match *self {
            Value::Int(i) => Some(i as f64),
            Value::Float(x) => Some(x),
            _ => None,
        }
    }

    /// The value as a string, when it is one.
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::Str(s) => Some(s),
            _ => None,
        }
    }

    /// The value as an integer, when it is one.
    pub fn as_i64(&self) -> Option<i64> {
        match *self {
            Value::Int(i) => Some(i),
            _ => None,
        }
    }

    /// A short name of the value's type, for error messages.
    pub fn type_name(&self) -> &'static str {
        match self {
            Value::Int(_) => "an integer",
            Value::Float(_) => "a float",
            Value::Bool(_) => "a boolean",
            Value::Str(_) => "a string",
        }
    }

    /// A scalar TOML value; tables, arrays and dates are not values.
    fn from_toml(v: &toml::Value) -> Result<Value, ValueError> {
        match v {
            toml::Value::Integer(i) => Ok(Value::Int(*i)),
            toml::Value::Float(x) if x.is_finite() => Ok(Value::Float(*x)),
            toml::Value::Float(x) => Err(ValueError(format!("values must be finite, got {x}"))),
            toml::Value::Boolean(b) => Ok(Value::Bool(*b)),
            toml::Value::String(s) => Ok(Value::Str(s.clone())),
            toml::Value::Datetime(_) => Err(ValueError("dates are not parameter values".into())),
            toml::Value::Array(_) => Err(ValueError("lists cannot be nested".into())),
            toml::Value::Table(_) => Err(ValueError("a table inside a list is not a value".into())),
        }
    }
}

/// Expand a manifest value into the list of values it stands for: a scalar
/// is one value, an array is its elements, and a table is a range
/// (`{ from, to, step }` or `{ from, to, count }`, both ends included).
pub fn expand_values(v: &toml::Value) -> Result<Vec<Value>, ValueError> {
    let values = match v {
        toml::Value::Array(items) => {
            if items.is_empty() {
                return Err(ValueError("a list of values must not be empty".into()));
            }
            items
                .iter()
                .map(Value::from_toml)
                .collect::<Result<Vec<_>, _>>()?
        }
        toml::Value::Table(t) => expand_range(t)?,
        scalar => vec![Value::from_toml(scalar)?],
    };
    if values.len() > MAX_VALUES {
        return Err(ValueError(format!(
            "expands to {} values, more than the limit of {MAX_VALUES}",
            values.len()
        )));
    }
    Ok(values)
}

/// A range table: `from` and `to` (both included) with either `step` or
/// `count`. Integer `from`, `to` and `step` give integers; otherwise floats.
fn expand_range(t: &toml::Table) -> Result<Vec<Value>, ValueError> {
    const EXPECTED: &str = "a range is `{ from, to, step }` or `{ from, to, count }`";
    for key in t.keys() {
        if !matches!(key.as_str(), "from" | "to" | "step" | "count") {
            return Err(ValueError(format!(
                "unknown key `{key}` in a range ({EXPECTED})"
            )));
        }
    }
    let get = |k: &str| -> Result<&toml::Value, ValueError> {
        t.get(k)
            .ok_or_else(|| ValueError(format!("range lacks `{k}` ({EXPECTED})")))
    };
    let number = |k: &str| -> Result<f64, ValueError> {
        match get(k)? {
            toml::Value::Integer(i) => Ok(*i as f64),
            toml::Value::Float(x) if x.is_finite() => Ok(*x),
            other => Err(ValueError(format!(
                "range `{k}` must be a finite number, got {other}"
            ))),
        }
    };
    let (from, to) = (number("from")?, number("to")?);
    match (t.get("step"), t.get("count")) {
        (Some(_), Some(_)) => Err(ValueError(format!(
            "a range has `step` or `count`, not both ({EXPECTED})"
        ))),
        (None, None) => Err(ValueError(format!(
            "range lacks `step` or `count` ({EXPECTED})"
        ))),
        (Some(step_value), None) => {
            let step = number("step")?;
            if step == 0.0 {
                return Err(ValueError("range `step` must not be 0".into()));
            }
            if (to - from) * step < 0.0 {
                return Err(ValueError(format!(
                    "range `step` = {step} never gets from {from} to {to} (wrong sign)"
                )));
            }
            if let (toml::Value::Integer(a), toml::Value::Integer(b), toml::Value::Integer(s)) =
                (get("from")?, get("to")?, step_value)
            {
                let n = (i128::from(*b) - i128::from(*a)) / i128::from(*s) + 1;
                check_count(n as f64)?;
                return Ok((0..n as i64).map(|i| Value::Int(a + i * s)).collect());
            }
            // A small tolerance so that 0.1 steps from 0 reach 1.0 despite
            // rounding: (1.0 - 0.0) / 0.1 = 9.999999999999998.
            let n = ((to - from) / step + 1e-9).floor() + 1.0;
            check_count(n)?;
            Ok((0..n as usize)
                .map(|i| Value::Float(tidy(from + i as f64 * step)))
                .collect())
        }
        (None, Some(count)) => {
            let count = match count {
                toml::Value::Integer(c) if *c >= 2 => *c,
                toml::Value::Integer(1) if from == to => 1,
                other => {
                    return Err(ValueError(format!(
                        "range `count` must be an integer of at least 2 (or 1 with from = to), got {other}"
                    )))
                }
            };
            check_count(count as f64)?;
            if count == 1 {
                return Ok(vec![Value::from_toml(get("from")?)?]);
            }
            let gaps = count - 1;
            if let (toml::Value::Integer(a), toml::Value::Integer(b)) = (get("from")?, get("to")?) {
                // Checked: from = i64::MIN, to = i64::MAX must not overflow.
                if let Some(span) = b.checked_sub(*a).filter(|d| d % gaps == 0) {
                    let s = span / gaps;
                    return Ok((0..count).map(|i| Value::Int(a + i * s)).collect());
                }
            }
            Ok((0..count)
                .map(|i| Value::Float(tidy(from + (to - from) * i as f64 / gaps as f64)))
                .collect())
        }
    }
}

fn check_count(n: f64) -> Result<(), ValueError> {
    if n > MAX_VALUES as f64 {
        Err(ValueError(format!(
            "range has {n} values, more than the limit of {MAX_VALUES}"
        )))
    } else {
        Ok(())
    }
}

/// Round to 13 significant digits, so that `0.1 * 3` is written as `0.3`
/// and not `0.30000000000000004` in tables and run keys; 13 digits keep
/// every value a manifest can sensibly ask for.
fn tidy(x: f64) -> f64 {
    format!("{x:.12e}").parse().unwrap_or(x)
}

/// One parameter of a block of the manifest (`[fixed]`, a `[[sweep]]`,
/// `[quick]`), with its values and where it is written (a byte range of
/// the manifest, for error messages).
#[derive(Clone, Debug, PartialEq)]
pub struct ManifestParam {
    /// The parameter name (the TOML key).
    pub name: String,
    /// Its values, in the order written; one value for a scalar.
    pub values: Vec<Value>,
    /// Byte range of the value in the manifest text.
    pub span: Range<usize>,
}

/// One `[[sweep]]` block: a name and its parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// The sweep's name (the `sweep` column of `data.csv`).
    pub name: String,
    /// Its parameters in the order written.
    pub params: Vec<ManifestParam>,
    /// Byte range of the block in the manifest text.
    pub span: Range<usize>,
}

/// One parameter of one run.
#[derive(Clone, Debug, PartialEq)]
pub struct RunParam {
    /// The parameter name.
    pub name: String,
    /// Its value in this run (templates already filled in).
    pub value: Value,
    /// Where the value was written in the manifest.
    pub span: Range<usize>,
}

/// One run of a sweep: one value for every parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct RunPoint {
    /// The sweep this run belongs to.
    pub sweep: String,
    /// Every parameter of the run, the `[fixed]` ones first.
    pub params: Vec<RunParam>,
}

impl RunPoint {
    /// The parameter called `name`.
    pub fn param(&self, name: &str) -> Option<&RunParam> {
        self.params.iter().find(|p| p.name == name)
    }

    /// The value of the parameter called `name`.
    pub fn get(&self, name: &str) -> Option<&Value> {
        self.param(name).map(|p| &p.value)
    }

    /// A one-line description for progress bars and error messages:
    /// `resolutions: resolution=300x225 sampler=centre`, listing only
    /// the parameters in `shown` (those that vary somewhere).
    pub fn describe(&self, shown: &[String]) -> String {
        let mut s = self.sweep.clone();
        s.push(':');
        for p in self.params.iter().filter(|p| shown.contains(&p.name)) {
            s.push_str(&format!(" {}={}", p.name, p.value));
        }
        s
    }
}

/// `sweep`'s parameters merged over `fixed`: the fixed ones it does not
/// set, then its own.
fn sweep_params<'a>(fixed: &'a [ManifestParam], sweep: &'a Sweep) -> Vec<&'a ManifestParam> {
    let mut params: Vec<&ManifestParam> = fixed
        .iter()
        .filter(|f| !sweep.params.iter().any(|p| p.name == f.name))
        .collect();
    params.extend(sweep.params.iter());
    params
}

/// The product of the parameters' value counts; `None` past `usize`.
fn run_count(params: &[&ManifestParam]) -> Option<usize> {
    params
        .iter()
        .try_fold(1usize, |n, p| n.checked_mul(p.values.len()))
}

/// How many runs the sweeps have in all, before any is expanded; `None`
/// past `usize`.
pub fn total_runs(fixed: &[ManifestParam], sweeps: &[Sweep]) -> Option<usize> {
    sweeps.iter().try_fold(0usize, |total, sweep| {
        total.checked_add(run_count(&sweep_params(fixed, sweep))?)
    })
}

/// The runs of `sweep`: its parameters merged over `fixed` (a sweep's value
/// replaces a fixed one of the same name), expanded as a cartesian product
/// with the first parameter varying slowest, and string templates filled.
/// Errors carry the byte range they concern.
pub fn expand_sweep(fixed: &[ManifestParam], sweep: &Sweep) -> Result<Vec<RunPoint>, SweepError> {
    let params = sweep_params(fixed, sweep);
    let count = run_count(&params)
        .filter(|&n| n <= MAX_RUNS)
        .ok_or_else(|| SweepError {
            span: sweep.span.clone(),
            message: format!(
                "sweep `{}` has more than {MAX_RUNS} runs; split it",
                sweep.name
            ),
        })?;
    let mut runs = Vec::with_capacity(count);
    let mut index = vec![0usize; params.len()];
    for _ in 0..count {
        let raw: Vec<RunParam> = params
            .iter()
            .zip(&index)
            .map(|(p, &i)| RunParam {
                name: p.name.clone(),
                value: p.values[i].clone(),
                span: p.span.clone(),
            })
            .collect();
        let mut filled = raw.clone();
        for p in &mut filled {
            if let Value::Str(s) = &p.value {
                let lookup = |name: &str| raw.iter().find(|q| q.name == name).map(|q| &q.value);
                let text = fill_template(s, lookup).map_err(|e| SweepError {
                    span: p.span.clone(),
                    message: format!("sweep `{}`, parameter `{}`: {e}", sweep.name, p.name),
                })?;
                p.value = Value::Str(text);
            }
        }
        runs.push(RunPoint {
            sweep: sweep.name.clone(),
            params: filled,
        });
        // Odometer increment, last parameter fastest.
        for k in (0..index.len()).rev() {
            index[k] += 1;
            if index[k] < params[k].values.len() {
                break;
            }
            index[k] = 0;
        }
    }
    Ok(runs)
}

/// One `{…}` field of a template.
struct Field<'a> {
    name: &'a str,
    /// Zero-pad integers to this many digits (`{name:03}`).
    zero_pad: Option<usize>,
}

/// Split a template into literal text and fields; `{{` and `}}` are
/// literal braces.
fn parse_template(s: &str) -> Result<Vec<Result<String, Field<'_>>>, ValueError> {
    let mut parts = Vec::new();
    let mut literal = String::new();
    let mut rest = s;
    while let Some(c) = rest.chars().next() {
        if rest.starts_with("{{") || rest.starts_with("}}") {
            literal.push(c);
            rest = &rest[2..];
        } else if c == '{' {
            let end = rest.find('}').ok_or_else(|| {
                ValueError(format!("unclosed `{{` in `{s}` (write `{{{{` for a brace)"))
            })?;
            let inner = &rest[1..end];
            let (name, spec) = match inner.split_once(':') {
                Some((n, spec)) => (n, Some(spec)),
                None => (inner, None),
            };
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(ValueError(format!(
                    "`{{{inner}}}` in `{s}` does not name a parameter"
                )));
            }
            let zero_pad = match spec {
                None => None,
                Some(spec) => match spec.strip_prefix('0').map(str::parse::<usize>) {
                    Some(Ok(w)) if w <= 32 => Some(w),
                    _ => {
                        return Err(ValueError(format!(
                            "format `{spec}` in `{s}` is not supported (only `0W`, \
                             zero padding to W digits, as in `{{{name}:02}}`)"
                        )))
                    }
                },
            };
            parts.push(Ok(std::mem::take(&mut literal)));
            parts.push(Err(Field { name, zero_pad }));
            rest = &rest[end + 1..];
        } else if c == '}' {
            return Err(ValueError(format!(
                "unmatched `}}` in `{s}` (write `}}}}` for a brace)"
            )));
        } else {
            literal.push(c);
            rest = &rest[c.len_utf8()..];
        }
    }
    parts.push(Ok(literal));
    Ok(parts)
}

/// The parameter names a string refers to as `{name}`; empty for plain
/// strings and for strings that are not valid templates.
pub fn template_names(s: &str) -> Vec<String> {
    parse_template(s)
        .map(|parts| {
            parts
                .into_iter()
                .filter_map(|p| p.err().map(|f| f.name.to_string()))
                .collect()
        })
        .unwrap_or_default()
}

/// Fill the `{name}` fields of `s` with the values `lookup` gives.
pub fn fill_template<'v>(
    s: &str,
    lookup: impl Fn(&str) -> Option<&'v Value>,
) -> Result<String, ValueError> {
    let mut out = String::new();
    for part in parse_template(s)? {
        match part {
            Ok(text) => out.push_str(&text),
            Err(field) => {
                let v = lookup(field.name).ok_or_else(|| {
                    ValueError(format!(
                        "`{{{}}}` in `{s}` names no parameter of this run",
                        field.name
                    ))
                })?;
                match (field.zero_pad, v) {
                    (None, v) => out.push_str(&v.to_string()),
                    (Some(w), Value::Int(i)) => out.push_str(&format!("{i:0w$}")),
                    (Some(_), other) => {
                        return Err(ValueError(format!(
                            "`{{{}:0…}}` in `{s}` pads integers, but `{}` is {}",
                            field.name,
                            field.name,
                            other.type_name()
                        )))
                    }
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toml_value(s: &str) -> toml::Value {
        let t: toml::Table = toml::from_str(&format!("v = {s}")).unwrap();
        t["v"].clone()
    }

    #[test]
    fn ranges_include_both_ends() {
        let ints = expand_values(&toml_value("{ from = 1, to = 20, step = 1 }")).unwrap();
        assert_eq!(ints.len(), 20);
        assert_eq!(ints[19], Value::Int(20));
        let down = expand_values(&toml_value("{ from = 10, to = 0, step = -5 }")).unwrap();
        assert_eq!(down, vec![Value::Int(10), Value::Int(5), Value::Int(0)]);
        let tenths = expand_values(&toml_value("{ from = 0.0, to = 1.0, step = 0.1 }")).unwrap();
        assert_eq!(tenths.len(), 11);
        assert_eq!(tenths[3], Value::Float(0.3));
        let lin = expand_values(&toml_value("{ from = 0, to = 1, count = 5 }")).unwrap();
        assert_eq!(lin[1], Value::Float(0.25));
        let even = expand_values(&toml_value("{ from = 0, to = 8, count = 5 }")).unwrap();
        assert_eq!(even[4], Value::Int(8));
    }

    #[test]
    fn bad_ranges_are_errors() {
        for bad in [
            "{ from = 0, to = 1, step = 0 }",
            "{ from = 0, to = 1, step = -1 }",
            "{ from = 0, to = 1 }",
            "{ from = 0, to = 1, step = 1, count = 2 }",
            "{ from = 0, to = 1e9, step = 1e-3 }",
            "{ from = 0, to = 1, count = 0 }",
            "{ from = 0, to = 1, stride = 1 }",
            "{ from = \"a\", to = 1, step = 1 }",
            "[]",
            "[[1]]",
        ] {
            assert!(expand_values(&toml_value(bad)).is_err(), "{bad}");
        }
    }

    #[test]
    fn templates_fill_and_pad() {
        let v = Value::Int(7);
        let look = |n: &str| (n == "i").then_some(&v);
        assert_eq!(fill_template("s-{i:02}.toml", look).unwrap(), "s-07.toml");
        assert_eq!(fill_template("{{i}}{i}", look).unwrap(), "{i}7");
        assert!(fill_template("{j}", look).is_err());
        assert!(fill_template("{i", look).is_err());
        assert!(fill_template("{i:x}", look).is_err());
        assert_eq!(template_names("a{i}b{j:03}"), vec!["i", "j"]);
    }
}
