//! Every number of a TOML document checked before it is used: the scene
//! format's numbers are `f32`, so a float must be finite (TOML writes
//! `nan`, `inf` and `-inf`) and within `f32`'s range (1e39 is finite as the
//! `f64` TOML reads but ∞ as the `f32` the renderer computes with). A bad
//! number is an error naming its field by path (`camera.eye[2]`,
//! `sphere[1].radius`) and its line and column; without this check a NaN
//! eye surfaced as "eye and look_at coincide" and an ∞ radius as a
//! missing image.

use super::{line_col, InputError, Place};
use std::path::Path;
use toml_edit::{ImDocument, Item, Value};

/// Check every float of `text` (a TOML document; syntax errors are left
/// to the deserialiser, which reports them better).
pub fn check_floats(text: &str, path: &Path) -> Result<(), InputError> {
    let Ok(doc) = ImDocument::parse(text) else {
        return Ok(());
    };
    let mut bad = None;
    walk_table(doc.as_table().iter(), "", &mut bad);
    match bad {
        None => Ok(()),
        Some((field, value, span)) => {
            let place = span.map_or(Place::File, |s| {
                let (l, c) = line_col(text, s.start);
                Place::LineCol(l, c)
            });
            let why = if value.is_nan() {
                "is not a number (nan)".to_string()
            } else if value.is_infinite() {
                "is infinite".to_string()
            } else {
                format!("= {value:e} is beyond the range of a 32-bit float (±3.4e38)")
            };
            Err(InputError::new(
                path,
                place,
                format!("`{field}` {why}: every number of a scene must be finite"),
            ))
        }
    }
}

type Bad = Option<(String, f64, Option<std::ops::Range<usize>>)>;

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

fn walk_table<'a>(entries: impl Iterator<Item = (&'a str, &'a Item)>, prefix: &str, bad: &mut Bad) {
    for (key, item) in entries {
        if bad.is_some() {
            return;
        }
        let field = join(prefix, key);
        match item {
            Item::None => {}
            Item::Value(v) => walk_value(v, &field, bad),
            Item::Table(t) => walk_table(t.iter(), &field, bad),
            Item::ArrayOfTables(a) => {
                for (i, t) in a.iter().enumerate() {
                    walk_table(t.iter(), &format!("{field}[{i}]"), bad);
                }
            }
        }
    }
}

fn walk_value(v: &Value, field: &str, bad: &mut Bad) {
    if bad.is_some() {
        return;
    }
    match v {
        Value::Float(f) => {
            let x = *f.value();
            if !x.is_finite() || x.abs() > f64::from(f32::MAX) {
                *bad = Some((field.to_string(), x, f.span()));
            }
        }
        Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                walk_value(v, &format!("{field}[{i}]"), bad);
            }
        }
        Value::InlineTable(t) => {
            for (k, v) in t.iter() {
                walk_value(v, &join(field, k), bad);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        check_floats(text, Path::new("s.toml"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn names_the_field_line_and_reason() {
        let e = err("[camera]\neye = [0.0, 0.0, nan]\n");
        assert!(e.starts_with("s.toml:2:"), "{e}");
        assert!(e.contains("`camera.eye[2]` is not a number"), "{e}");
        let e = err("[[sphere]]\nradius = 1.0\n[[sphere]]\nradius = -inf\n");
        assert!(e.contains("`sphere[1].radius` is infinite"), "{e}");
        assert!(err("[materials.m]\ncolor = { r = 1e39 }\n").contains("materials.m.color.r"));
        assert!(check_floats("a = 3.0e38\nb = [1, 2.5]\n", Path::new("s")).is_ok());
    }
}
