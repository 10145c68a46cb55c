//! Serde plumbing for typed parameters: a [`Deserializer`] over the
//! parameters of one run (each parameter a field, each [`Value`] a scalar)
//! and [`field_names`], which asks a derived `Deserialize` for the names of
//! its fields without deserializing anything.
//!
//! Errors are [`RunParamError`]s: a value that fails to deserialize is tagged
//! with its parameter's name, so the manifest can point at the line where
//! that value is written.

use super::RunParamError;
use crate::experiment::sweep::{RunParam, Value};
use serde::de::{self, DeserializeOwned, DeserializeSeed, IntoDeserializer, MapAccess, Visitor};
use serde::{forward_to_deserialize_any, Deserialize, Deserializer};

/// Deserialize `T` (a struct of parameters) from `params`, one field per
/// parameter.
pub fn from_params<T: DeserializeOwned>(params: &[&RunParam]) -> Result<T, RunParamError> {
    T::deserialize(RunDeserializer { params })
}

/// The field names of a struct that derives `Deserialize` (after
/// `rename`s), in declaration order; empty for anything else.
pub fn field_names<'de, T: Deserialize<'de>>() -> &'static [&'static str] {
    let mut fields: &'static [&'static str] = &[];
    // The probe always fails after recording the names: nothing is built.
    let _ = T::deserialize(FieldProbe(&mut fields));
    fields
}

/// The parameters of a run, as a map from name to value.
struct RunDeserializer<'a> {
    params: &'a [&'a RunParam],
}

impl<'de> Deserializer<'de> for RunDeserializer<'_> {
    type Error = RunParamError;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, RunParamError> {
        visitor.visit_map(RunMap {
            params: self.params.iter(),
            current: None,
        })
    }

    forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map struct enum identifier ignored_any
    }
}

struct RunMap<'a> {
    params: std::slice::Iter<'a, &'a RunParam>,
    current: Option<&'a RunParam>,
}

impl<'de> MapAccess<'de> for RunMap<'_> {
    type Error = RunParamError;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, RunParamError> {
        let Some(p) = self.params.next() else {
            return Ok(None);
        };
        self.current = Some(p);
        let name: de::value::StrDeserializer<'_, RunParamError> =
            p.name.as_str().into_deserializer();
        seed.deserialize(name)
            .map(Some)
            .map_err(|e| e.of_param(&p.name))
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(
        &mut self,
        seed: V,
    ) -> Result<V::Value, RunParamError> {
        let p = self
            .current
            .take()
            .ok_or_else(|| <RunParamError as de::Error>::custom("a value without its name"))?;
        seed.deserialize(ValueDeserializer(&p.value))
            .map_err(|e| e.of_param(&p.name))
    }
}

/// One parameter value: a scalar of its own type. A value that is present
/// is `Some` for an `Option` field.
struct ValueDeserializer<'a>(&'a Value);

impl<'de> Deserializer<'de> for ValueDeserializer<'_> {
    type Error = RunParamError;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, RunParamError> {
        match self.0 {
            Value::Int(i) => visitor.visit_i64(*i),
            Value::Float(x) => visitor.visit_f64(*x),
            Value::Bool(b) => visitor.visit_bool(*b),
            Value::Str(s) => visitor.visit_str(s),
        }
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, RunParamError> {
        visitor.visit_some(self)
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, RunParamError> {
        visitor.visit_newtype_struct(self)
    }

    /// A string names a unit variant (`averaging = "gamma"`).
    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, RunParamError> {
        match self.0 {
            Value::Str(s) => visitor.visit_enum(s.as_str().into_deserializer()),
            _ => self.deserialize_any(visitor),
        }
    }

    forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf unit unit_struct seq tuple
        tuple_struct map struct identifier ignored_any
    }
}

/// A deserializer that records the field list a derived struct asks for
/// and then gives up.
struct FieldProbe<'a>(&'a mut &'static [&'static str]);

impl<'de> Deserializer<'de> for FieldProbe<'_> {
    type Error = de::value::Error;

    fn deserialize_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, Self::Error> {
        Err(de::Error::custom("not a struct"))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, Self::Error> {
        *self.0 = fields;
        Err(de::Error::custom("field names recorded"))
    }

    forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map enum identifier ignored_any
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct P {
        name: String,
        #[serde(default)]
        count: Option<u32>,
        #[serde(default)]
        gain: f64,
        #[serde(rename = "on")]
        enabled: Option<bool>,
    }

    fn param(name: &str, value: Value) -> RunParam {
        RunParam {
            name: name.into(),
            value,
            span: 0..0,
        }
    }

    fn parse(params: &[RunParam]) -> Result<P, RunParamError> {
        from_params(&params.iter().collect::<Vec<_>>())
    }

    #[test]
    fn fields_are_read_by_name_and_type() {
        let p = parse(&[
            param("gain", Value::Int(2)),
            param("name", Value::Str("a".into())),
            param("on", Value::Bool(true)),
        ])
        .unwrap();
        assert_eq!(
            p,
            P {
                name: "a".into(),
                count: None,
                gain: 2.0,
                enabled: Some(true)
            }
        );
        assert_eq!(field_names::<P>(), ["name", "count", "gain", "on"]);
        assert!(field_names::<u32>().is_empty());
    }

    #[test]
    fn errors_name_the_parameter() {
        let e = parse(&[
            param("name", Value::Str("a".into())),
            param("count", Value::Float(1.5)),
        ])
        .unwrap_err();
        assert_eq!(e.param.as_deref(), Some("count"));
        assert!(e.message.contains("must be a non-negative integer"), "{e}");
        assert!(e.message.contains("1.5"), "{e}");

        let e = parse(&[
            param("name", Value::Str("a".into())),
            param("count", Value::Int(-3)),
        ])
        .unwrap_err();
        assert_eq!(e.param.as_deref(), Some("count"));

        let e = parse(&[param("nmae", Value::Str("a".into()))]).unwrap_err();
        assert_eq!(e.param.as_deref(), Some("nmae"));
        assert!(e.message.contains("unknown parameter"), "{e}");
        assert!(e.message.contains("`name`"), "{e}");

        let e = parse(&[param("gain", Value::Float(1.0))]).unwrap_err();
        assert_eq!(e.param, None);
        assert!(e.message.contains("`name` is required"), "{e}");

        let e = parse(&[param("name", Value::Int(1))]).unwrap_err();
        assert!(e.message.contains("must be a string"), "{e}");
    }
}
