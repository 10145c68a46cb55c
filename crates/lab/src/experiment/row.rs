//! Rows of `data.csv` as typed structs: a study's row type derives
//! `serde::Serialize`, its fields are the study's columns, and
//! [`record`] turns a row into column names and cells. The same code gives
//! the header (from a template row, see
//! [`Study::template`](super::study::Study::template)) and every row, so a
//! column is named once and a misspelt column cannot leave an empty cell.
//!
//! How values become columns and cells:
//!
//! - a field of a scalar type is one column named after the field: integers
//!   and booleans as Rust writes them, strings as they are, `None` and `()`
//!   as an empty cell, `Some(v)` as `v`;
//! - a field holding a sequence is one column per element, named
//!   `FIELD_1`, `FIELD_2`, … (`render_s: Vec<Secs>` gives `render_s_1` …
//!   `render_s_N`);
//! - `#[serde(flatten)]` splices a struct's fields, or a map's entries (a
//!   custom `Serialize` that builds names such as `primary_rays`), in
//!   place; other nested structs are an error.
//!
//! Floats say how they are written: [`Secs`] (seconds, nanosecond
//! resolution), [`Fixed`] (D decimals), [`Sci`] (scientific, D decimals) and
//! [`Exp`] (shortest scientific form, NaN as an empty cell). A bare `f64`
//! is written in Rust's shortest round-trip form.

use raylab::stats::Counters;
use serde::ser::{self, Impossible, Serialize, SerializeMap, SerializeSeq, SerializeStruct};
use std::fmt;

/// One row as text: the column names and, in the same order, the cells.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Record {
    /// Column names.
    pub columns: Vec<String>,
    /// One cell per column.
    pub cells: Vec<String>,
}

impl Record {
    /// The cell of column `name`.
    pub fn get(&self, name: &str) -> Option<&str> {
        self.columns
            .iter()
            .position(|c| c == name)
            .map(|i| self.cells[i].as_str())
    }
}

/// A row type that cannot be written as columns (a programming error in a
/// study, which the runner reports).
#[derive(Debug)]
pub struct RowError(String);

impl fmt::Display for RowError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RowError {}

impl ser::Error for RowError {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        RowError(msg.to_string())
    }
}

/// The columns and cells of `row` (a struct or map; see the module docs).
pub fn record<R: Serialize + ?Sized>(row: &R) -> Result<Record, RowError> {
    let mut rec = Record::default();
    row.serialize(RowSerializer { rec: &mut rec })?;
    let mut seen = std::collections::HashSet::new();
    if let Some(dup) = rec.columns.iter().find(|c| !seen.insert(c.as_str())) {
        return Err(RowError(format!("column `{dup}` appears twice in a row")));
    }
    Ok(rec)
}

/// Seconds, written with nanosecond resolution (that of `Instant` on
/// Linux): `0.001234567`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Secs(pub f64);

/// A float with `D` decimals: `Fixed::<3>(1.0)` is `1.000`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Fixed<const D: usize>(pub f64);

/// A float in scientific form with `D` decimals: `Sci::<6>(0.5)` is
/// `5.000000e-1`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sci<const D: usize>(pub f64);

/// A float (`f64`, or `f32` written as an `f32`) in the shortest
/// scientific form (`1.5e-3`); NaN, "no value", is an empty cell.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Exp<T = f64>(pub T);

impl Serialize for Secs {
    fn serialize<S: ser::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(&format_args!("{:.9}", self.0))
    }
}

impl<const D: usize> Serialize for Fixed<D> {
    fn serialize<S: ser::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(&format_args!("{:.*}", D, self.0))
    }
}

impl<const D: usize> Serialize for Sci<D> {
    fn serialize<S: ser::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(&format_args!("{:.*e}", D, self.0))
    }
}

impl<T: fmt::LowerExp + PartialEq> Serialize for Exp<T> {
    fn serialize<S: ser::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if is_nan(&self.0) {
            s.serialize_str("")
        } else {
            s.collect_str(&format_args!("{:e}", self.0))
        }
    }
}

/// Whether `x` is NaN, the one value unequal to itself.
#[allow(clippy::eq_op)]
fn is_nan<T: PartialEq>(x: &T) -> bool {
    x != x
}

/// Every counter of [`Counters::named`], one column each (flatten it into
/// a row).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CounterCells(pub Counters);

impl Serialize for CounterCells {
    fn serialize<S: ser::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let named = self.0.named();
        let mut map = s.serialize_map(Some(named.len()))?;
        for (name, v) in named {
            map.serialize_entry(name, &v)?;
        }
        map.end()
    }
}

/// The row itself: a struct or a map of columns.
struct RowSerializer<'a> {
    rec: &'a mut Record,
}

/// One value of a row, under the column name `key`.
struct CellSerializer<'a> {
    rec: &'a mut Record,
    key: String,
}

impl CellSerializer<'_> {
    fn push(self, cell: String) -> Result<(), RowError> {
        self.rec.columns.push(self.key);
        self.rec.cells.push(cell);
        Ok(())
    }
}

fn not_a_row<T>(what: &str) -> Result<T, RowError> {
    Err(RowError(format!(
        "a row must be a struct or a map of columns, not {what}"
    )))
}

macro_rules! reject {
    ($($method:ident($($arg:ty),*) -> $ok:ty;)*) => {
        $(fn $method(self, $(_: $arg),*) -> Result<$ok, RowError> {
            not_a_row(stringify!($method))
        })*
    };
}

impl<'a> ser::Serializer for RowSerializer<'a> {
    type Ok = ();
    type Error = RowError;
    type SerializeSeq = Impossible<(), RowError>;
    type SerializeTuple = Impossible<(), RowError>;
    type SerializeTupleStruct = Impossible<(), RowError>;
    type SerializeTupleVariant = Impossible<(), RowError>;
    type SerializeMap = Columns<'a>;
    type SerializeStruct = Columns<'a>;
    type SerializeStructVariant = Impossible<(), RowError>;

    reject! {
        serialize_bool(bool) -> ();
        serialize_i8(i8) -> ();
        serialize_i16(i16) -> ();
        serialize_i32(i32) -> ();
        serialize_i64(i64) -> ();
        serialize_u8(u8) -> ();
        serialize_u16(u16) -> ();
        serialize_u32(u32) -> ();
        serialize_u64(u64) -> ();
        serialize_f32(f32) -> ();
        serialize_f64(f64) -> ();
        serialize_char(char) -> ();
        serialize_str(&str) -> ();
        serialize_bytes(&[u8]) -> ();
        serialize_none() -> ();
        serialize_unit() -> ();
        serialize_unit_struct(&'static str) -> ();
        serialize_unit_variant(&'static str, u32, &'static str) -> ();
        serialize_seq(Option<usize>) -> Self::SerializeSeq;
        serialize_tuple(usize) -> Self::SerializeTuple;
        serialize_tuple_struct(&'static str, usize) -> Self::SerializeTupleStruct;
        serialize_tuple_variant(&'static str, u32, &'static str, usize) -> Self::SerializeTupleVariant;
        serialize_struct_variant(&'static str, u32, &'static str, usize) -> Self::SerializeStructVariant;
    }

    fn serialize_some<T: Serialize + ?Sized>(self, _: &T) -> Result<(), RowError> {
        not_a_row("an option")
    }

    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        value: &T,
    ) -> Result<(), RowError> {
        value.serialize(self)
    }

    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &T,
    ) -> Result<(), RowError> {
        not_a_row("an enum")
    }

    fn serialize_map(self, _: Option<usize>) -> Result<Columns<'a>, RowError> {
        Ok(Columns {
            rec: self.rec,
            key: None,
        })
    }

    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Columns<'a>, RowError> {
        self.serialize_map(None)
    }
}

/// The columns of a row, field by field (or entry by entry).
struct Columns<'a> {
    rec: &'a mut Record,
    key: Option<String>,
}

impl SerializeStruct for Columns<'_> {
    type Ok = ();
    type Error = RowError;

    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), RowError> {
        value.serialize(CellSerializer {
            rec: self.rec,
            key: key.to_string(),
        })
    }

    fn end(self) -> Result<(), RowError> {
        Ok(())
    }
}

impl SerializeMap for Columns<'_> {
    type Ok = ();
    type Error = RowError;

    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<(), RowError> {
        let mut name = Record::default();
        key.serialize(CellSerializer {
            rec: &mut name,
            key: String::new(),
        })?;
        match name.cells.as_slice() {
            [k] if !k.is_empty() => {
                self.key = Some(k.clone());
                Ok(())
            }
            _ => Err(RowError("a column name must be a non-empty string".into())),
        }
    }

    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), RowError> {
        let key = self
            .key
            .take()
            .ok_or_else(|| RowError("a map value without its key".into()))?;
        value.serialize(CellSerializer { rec: self.rec, key })
    }

    fn end(self) -> Result<(), RowError> {
        Ok(())
    }
}

/// The elements of a sequence field: `FIELD_1`, `FIELD_2`, ….
struct Numbered<'a> {
    rec: &'a mut Record,
    key: String,
    next: usize,
}

impl SerializeSeq for Numbered<'_> {
    type Ok = ();
    type Error = RowError;

    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), RowError> {
        self.next += 1;
        value.serialize(CellSerializer {
            rec: self.rec,
            key: format!("{}_{}", self.key, self.next),
        })
    }

    fn end(self) -> Result<(), RowError> {
        Ok(())
    }
}

fn nested<T>(key: &str, what: &str) -> Result<T, RowError> {
    Err(RowError(format!(
        "column `{key}`: {what} is not a cell (flatten it into the row, or use a sequence)"
    )))
}

impl<'a> ser::Serializer for CellSerializer<'a> {
    type Ok = ();
    type Error = RowError;
    type SerializeSeq = Numbered<'a>;
    type SerializeTuple = Impossible<(), RowError>;
    type SerializeTupleStruct = Impossible<(), RowError>;
    type SerializeTupleVariant = Impossible<(), RowError>;
    type SerializeMap = Impossible<(), RowError>;
    type SerializeStruct = Impossible<(), RowError>;
    type SerializeStructVariant = Impossible<(), RowError>;

    fn serialize_bool(self, v: bool) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_i8(self, v: i8) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_i16(self, v: i16) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_i32(self, v: i32) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_i64(self, v: i64) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_u8(self, v: u8) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_u16(self, v: u16) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_u32(self, v: u32) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_u64(self, v: u64) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_f32(self, v: f32) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_f64(self, v: f64) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_char(self, v: char) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_str(self, v: &str) -> Result<(), RowError> {
        self.push(v.to_string())
    }
    fn serialize_bytes(self, _: &[u8]) -> Result<(), RowError> {
        let key = self.key;
        nested(&key, "bytes")
    }
    fn serialize_none(self) -> Result<(), RowError> {
        self.push(String::new())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<(), RowError> {
        value.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), RowError> {
        self.push(String::new())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), RowError> {
        self.push(String::new())
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
    ) -> Result<(), RowError> {
        self.push(variant.to_string())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        value: &T,
    ) -> Result<(), RowError> {
        value.serialize(self)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &T,
    ) -> Result<(), RowError> {
        nested(&self.key, "an enum with data")
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Numbered<'a>, RowError> {
        Ok(Numbered {
            rec: self.rec,
            key: self.key,
            next: 0,
        })
    }
    fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, RowError> {
        nested(&self.key, "a tuple")
    }
    fn serialize_tuple_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleStruct, RowError> {
        nested(&self.key, "a tuple struct")
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, RowError> {
        nested(&self.key, "an enum with data")
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, RowError> {
        nested(&self.key, "a map")
    }
    fn serialize_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStruct, RowError> {
        nested(&self.key, "a struct")
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, RowError> {
        nested(&self.key, "an enum with data")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Serialize;

    #[derive(Serialize, Default)]
    struct Inner {
        a: u32,
        b: Option<bool>,
    }

    #[derive(Serialize, Default)]
    struct Row {
        name: String,
        times: Vec<Secs>,
        #[serde(flatten)]
        inner: Inner,
        ratio: Fixed<2>,
        small: Sci<3>,
        maybe: Exp,
        #[serde(flatten)]
        counters: CounterCells,
    }

    #[test]
    fn fields_sequences_and_flattened_structs_become_columns() {
        let row = Row {
            name: "x".into(),
            times: vec![Secs(0.5), Secs(1.0)],
            inner: Inner { a: 3, b: None },
            ratio: Fixed(2.0 / 3.0),
            small: Sci(0.00125),
            maybe: Exp(f64::NAN),
            counters: CounterCells::default(),
        };
        let r = record(&row).unwrap();
        assert_eq!(
            r.columns[..8],
            ["name", "times_1", "times_2", "a", "b", "ratio", "small", "maybe"]
        );
        assert_eq!(
            r.cells[..8],
            [
                "x",
                "0.500000000",
                "1.000000000",
                "3",
                "",
                "0.67",
                "1.250e-3",
                ""
            ]
        );
        assert_eq!(r.columns[8], "camera_rays");
        assert_eq!(r.columns.len(), 8 + Counters::default().named().len());
        assert_eq!(r.get("a"), Some("3"));
        let e = record(&Exp(1.5)).unwrap_err();
        assert!(e.to_string().contains("struct"), "{e}");
    }

    #[test]
    fn nested_structs_and_duplicate_columns_are_errors() {
        #[derive(Serialize)]
        struct Nested {
            inner: Inner,
        }
        let e = record(&Nested {
            inner: Inner::default(),
        })
        .unwrap_err();
        assert!(e.to_string().contains("column `inner`"), "{e}");
        #[derive(Serialize)]
        struct Twice {
            a: u32,
            #[serde(flatten)]
            inner: Inner,
        }
        let e = record(&Twice {
            a: 1,
            inner: Inner::default(),
        })
        .unwrap_err();
        assert!(e.to_string().contains("`a` appears twice"), "{e}");
    }
}
