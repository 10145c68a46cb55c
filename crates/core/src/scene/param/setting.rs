//! Parameters set from the command line: `PATH=VALUE` (`raylab render
//! --set`, `raylab grad --set`). PATH is a name of the one parameter table
//! ([`SceneDescription::select`]: the names `raylab grad --param` takes);
//! VALUE is a number, or a list `[a,b,c]` of as many numbers as PATH
//! selects (a vector's three, a point's three, a triangle's nine, flat or
//! as points `[[x,y,z],…]`).
//!
//! Two steps, so that each error comes where it can be told:
//! [`Setting::parse`] reads the text alone (no `=`, a value that is not a
//! number or not finite), when the command line is parsed;
//! [`SceneDescription::apply_setting`] resolves PATH in a scene and writes
//! the numbers (a name the scene lacks, a value of the wrong shape).
//! Whether the scene is still valid is the scene file's own check, which
//! the loader runs on the result (`SceneSource::set` in `io::scene_file`).

use super::{ParamError, Selection, ValueShape};
use crate::scene::SceneDescription;

/// One `PATH=VALUE`.
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    /// The parameter's name as given (`light[0].intensity`).
    pub path: String,
    /// The value as given.
    pub value: SetValue,
}

/// The value of a [`Setting`]: one number, or a list of them.
#[derive(Clone, Debug, PartialEq)]
pub enum SetValue {
    /// `0.5`: for a path that selects one number.
    Number(f32),
    /// `[a,b,c]` (or points `[[x,y,z],…]`, flattened): for a path that
    /// selects as many numbers.
    List(Vec<f32>),
}

impl SetValue {
    /// The numbers, in order.
    pub fn numbers(&self) -> &[f32] {
        match self {
            SetValue::Number(v) => std::slice::from_ref(v),
            SetValue::List(v) => v,
        }
    }

    /// What it is, for messages: "a number", "a list of 2 numbers".
    fn describe(&self) -> String {
        match self {
            SetValue::Number(_) => "a number".into(),
            SetValue::List(v) if v.len() == 1 => "a list of 1 number".into(),
            SetValue::List(v) => format!("a list of {} numbers", v.len()),
        }
    }
}

/// Text that is not a `PATH=VALUE` (found without a scene).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SettingError {
    /// No `=` at all.
    #[error(
        "`{0}` has no `=`: expected PATH=VALUE, e.g. `light[0].intensity=0` or \
         `render.ambient=[2,2,2]`"
    )]
    NoEquals(String),
    /// Nothing before the `=`.
    #[error("no parameter before `=` in `{0}` (expected PATH=VALUE)")]
    NoPath(String),
    /// A value that does not read as a number or a list of numbers.
    #[error("{path}: {why}; VALUE is a number, or `[x,y,z]` for a vector")]
    Value {
        /// The parameter's name.
        path: String,
        /// What is wrong with the value.
        why: String,
    },
}

impl Setting {
    /// Parse `PATH=VALUE` (spaces around either are ignored). Every
    /// number must be finite in `f32`.
    pub fn parse(s: &str) -> Result<Self, SettingError> {
        let (path, value) = s
            .split_once('=')
            .ok_or_else(|| SettingError::NoEquals(s.to_string()))?;
        let path = path.trim();
        if path.is_empty() {
            return Err(SettingError::NoPath(s.to_string()));
        }
        let value = parse_value(value.trim()).map_err(|why| SettingError::Value {
            path: path.to_string(),
            why,
        })?;
        Ok(Self {
            path: path.to_string(),
            value,
        })
    }
}

/// A number, or a list of numbers, or a list of points `[x,y,z]`
/// (flattened).
fn parse_value(s: &str) -> Result<SetValue, String> {
    if s.is_empty() {
        return Err("no value after `=`".into());
    }
    let Some(inner) = s.strip_prefix('[') else {
        return number(s).map(SetValue::Number);
    };
    let inner = inner
        .strip_suffix(']')
        .ok_or_else(|| format!("`{s}` opens a list with `[` but does not end with `]`"))?;
    let items = split_items(inner).ok_or_else(|| format!("unbalanced brackets in `{s}`"))?;
    if items.iter().all(|i| i.is_empty()) && items.len() == 1 {
        return Err("an empty list `[]`".into());
    }
    let points = items.iter().any(|i| i.starts_with('['));
    let mut numbers = Vec::new();
    for item in items {
        match (points, item.strip_prefix('[')) {
            (true, Some(p)) => {
                let coords = p
                    .strip_suffix(']')
                    .map(|p| p.split(',').map(str::trim).collect::<Vec<_>>())
                    .filter(|c| c.len() == 3 && c.iter().all(|x| !x.contains(['[', ']'])))
                    .ok_or_else(|| format!("`{item}` is not a point `[x,y,z]`"))?;
                for c in coords {
                    numbers.push(number(c)?);
                }
            }
            (true, None) => {
                return Err(format!(
                    "`{s}` mixes numbers and points: give points `[[x,y,z],…]` or numbers \
                     `[a,b,…]`"
                ))
            }
            (false, _) => numbers.push(number(item)?),
        }
    }
    Ok(SetValue::List(numbers))
}

/// The comma-separated items of a list's inside, trimmed, splitting only
/// at commas outside brackets; `None` if the brackets do not balance.
fn split_items(inner: &str) -> Option<Vec<&str>> {
    let mut items = Vec::new();
    let (mut depth, mut start) = (0i32, 0);
    for (i, c) in inner.char_indices() {
        match c {
            '[' => depth += 1,
            ']' => {
                depth -= 1;
                if depth < 0 {
                    return None;
                }
            }
            ',' if depth == 0 => {
                items.push(inner[start..i].trim());
                start = i + 1;
            }
            _ => {}
        }
    }
    (depth == 0).then(|| {
        items.push(inner[start..].trim());
        items
    })
}

/// One finite `f32`, read as a scene file's number is (as an `f64`,
/// then rounded to `f32`), so that a value set here and the same text in
/// a scene file give the same bits.
fn number(s: &str) -> Result<f32, String> {
    if s.is_empty() {
        return Err("an empty item in the list".into());
    }
    match s.parse::<f64>() {
        Ok(v) if (v as f32).is_finite() => Ok(v as f32),
        Ok(_) => Err(format!(
            "`{s}` is not a finite number (single precision reaches ±{:e})",
            f32::MAX
        )),
        Err(_) => Err(format!("`{s}` is not a number")),
    }
}

/// Scene-file settings that are no parameters but have options of their
/// own: the option to use instead.
const OWN_OPTIONS: &[(&str, &str)] = &[
    ("width", "--width"),
    ("height", "--height"),
    ("max_depth", "--max-depth"),
    ("seed", "--seed"),
    ("sampler", "--sampler"),
    ("filter", "--filter"),
    ("accel", "--accel"),
];

impl SceneDescription {
    /// Resolve `setting`'s path in this description and write its value:
    /// a number where the path selects one number, otherwise a list of as
    /// many numbers as it selects. Nothing is written when it fails. No
    /// range check: [`SceneDescription::check`] says whether the result is
    /// a valid scene.
    pub fn apply_setting(&mut self, setting: &Setting) -> Result<Selection, ParamError> {
        let path = &setting.path;
        let error = |message: String| ParamError {
            path: path.clone(),
            message,
        };
        let selection = self.select(path).map_err(|e| {
            let field = path.rsplit('.').next().unwrap_or(path.as_str());
            match OWN_OPTIONS.iter().find(|(f, _)| *f == field) {
                Some((_, option)) => error(format!("{}; use {option}", e.message)),
                None => e,
            }
        })?;
        let n = selection.len();
        let fits = match &setting.value {
            SetValue::Number(_) => n == 1,
            SetValue::List(v) => n > 1 && v.len() == n,
        };
        if !fits {
            return Err(error(format!(
                "takes {}, got {}",
                self.expected(&selection),
                setting.value.describe()
            )));
        }
        for (id, &v) in selection.ids().zip(setting.value.numbers()) {
            self.set_value(id, v);
        }
        Ok(selection)
    }

    /// What a value for `selection` must be, in words.
    fn expected(&self, selection: &Selection) -> String {
        let n = selection.len();
        match (self.shape_of(selection.target), n) {
            (_, 1) => "a number".into(),
            (ValueShape::Vector, _) => format!(
                "a vector `[x,y,z]` (or one component: `{}.{}[0]=…`)",
                self.entity_name(selection.target.entity()),
                selection.target.key()
            ),
            (ValueShape::Points, 3) => "a point `[x,y,z]`".into(),
            (_, n) => format!(
                "{n} numbers: {} points `[[x,y,z],…]` or a flat list `[a,b,…]`",
                n / 3
            ),
        }
    }
}

/// A `--set` that does not apply to a scene, or leaves it invalid: the
/// parameter's name as given and what is wrong (for an invalid scene, the
/// message the scene file would get).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("--set {path}: {message}")]
pub struct SetError {
    pub path: String,
    pub message: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(s: &str) -> Result<SetValue, SettingError> {
        Setting::parse(s).map(|s| s.value)
    }

    #[test]
    fn numbers_lists_and_points_parse() {
        assert_eq!(value("camera.fov=50"), Ok(SetValue::Number(50.0)));
        assert_eq!(
            value(" light[0].intensity = -0.5e1 "),
            Ok(SetValue::Number(-5.0))
        );
        assert_eq!(
            value("render.ambient=[2, 2,2]"),
            Ok(SetValue::List(vec![2.0; 3]))
        );
        assert_eq!(
            value("triangle[0].vertices=[[0,0,0],[1,0,0],[0,1,0]]"),
            Ok(SetValue::List(vec![
                0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0
            ]))
        );
        let s = Setting::parse("sphere[1].center[2]=3").unwrap();
        assert_eq!(s.path, "sphere[1].center[2]");
    }

    #[test]
    fn bad_text_is_refused_with_its_cause() {
        for (text, want) in [
            ("camera.fov", "has no `=`"),
            ("=3", "no parameter before `=`"),
            ("camera.fov=", "no value after `=`"),
            ("camera.fov=abc", "`abc` is not a number"),
            ("camera.fov=inf", "`inf` is not a finite number"),
            ("camera.fov=NaN", "`NaN` is not a finite number"),
            ("camera.fov=1e39", "`1e39` is not a finite number"),
            ("camera.eye=[1,2", "does not end with `]`"),
            ("camera.eye=[1,,2]", "an empty item"),
            ("camera.eye=[]", "an empty list"),
            ("camera.eye=[1,2]]", "unbalanced brackets"),
            ("triangle[0].vertices=[[0,0],[1,0,0]]", "is not a point"),
            (
                "triangle[0].vertices=[[0,0,0],1]",
                "mixes numbers and points",
            ),
            ("triangle[0].vertices=[[[0,0,0]]]", "is not a point"),
        ] {
            let e = Setting::parse(text).unwrap_err().to_string();
            assert!(e.contains(want), "{text}: `{e}` lacks `{want}`");
        }
    }
}
