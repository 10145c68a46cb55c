//! The PLY header: the format line, the elements with their counts and
//! properties, and the [`Layout`] that says which properties of the vertex
//! and face elements hold the values we read. Part of the PLY reader
//! ([`super`]); the body readers ([`super::ascii`], [`super::binary`]) take
//! their scalar types and element descriptions from here.

use crate::io::mesh::{show, Lines};
use crate::io::InputError;
use std::path::Path;

/// The encoding of the body.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Format {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

/// The scalar types of PLY, under their old and their sized names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// Size in bytes in a binary body.
    pub(super) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The range of an integer type, `None` for floating point.
    pub(super) fn integer_range(self) -> Option<(i64, i64)> {
        match self {
            Scalar::I8 => Some((i8::MIN.into(), i8::MAX.into())),
            Scalar::U8 => Some((0, u8::MAX.into())),
            Scalar::I16 => Some((i16::MIN.into(), i16::MAX.into())),
            Scalar::U16 => Some((0, u16::MAX.into())),
            Scalar::I32 => Some((i32::MIN.into(), i32::MAX.into())),
            Scalar::U32 => Some((0, u32::MAX.into())),
            Scalar::F32 | Scalar::F64 => None,
        }
    }

    /// The name in messages (the old, unsized one).
    pub(super) fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
}

/// A property's type: one scalar, or a list with its count type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

/// One `property` line.
#[derive(Clone, Debug)]
pub(super) struct Property {
    pub(super) name: String,
    pub(super) kind: Kind,
}

/// One `element` line and its properties.
#[derive(Clone, Debug)]
pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: u64,
    pub(super) properties: Vec<Property>,
    /// Header line that declared it, for errors about its layout.
    pub(super) line: usize,
}

impl Element {
    /// Bytes one item takes at least: in binary, its scalars and list
    /// counts; in ASCII, one character and one separator per value.
    pub(super) fn min_item_bytes(&self, format: Format) -> usize {
        match format {
            Format::Ascii => 2 * self.properties.len(),
            _ => self
                .properties
                .iter()
                .map(|p| match p.kind {
                    Kind::Scalar(s) | Kind::List { count: s, .. } => s.size(),
                })
                .sum(),
        }
    }

    /// Size of one item in a binary body when it has no lists.
    pub(super) fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => Some(s.size()),
                Kind::List { .. } => None,
            })
            .sum()
    }
}

/// The parsed header.
#[derive(Debug)]
pub(super) struct Header {
    pub(super) format: Format,
    pub(super) elements: Vec<Element>,
    /// Byte offset where the body starts, just after `end_header`.
    pub(super) body_start: usize,
    /// Line number of `end_header`.
    pub(super) end_line: usize,
}

/// Parse the header at the start of `bytes`; errors name the line.
pub(super) fn parse_header(bytes: &[u8], path: &Path) -> Result<Header, InputError> {
    let at = |line: usize, message: String| InputError::line(path, line, message);
    let mut lines = Lines::new(bytes);
    if lines
        .next()
        .is_none_or(|first| first.bytes.trim_ascii() != b"ply")
    {
        return Err(at(1, "not a PLY file: the first line must be `ply`".into()));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for line in lines.by_ref() {
        let n = line.number;
        let text = std::str::from_utf8(line.bytes)
            .map_err(|_| at(n, "header line is not text (missing `end_header`?)".into()))?;
        let mut words = text.split_ascii_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            "comment" | "obj_info" => {}
            "format" => {
                if format.is_some() {
                    return Err(at(n, "second `format` line".into()));
                }
                format = Some(match words.next() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::BinaryLittleEndian,
                    Some("binary_big_endian") => Format::BinaryBigEndian,
                    other => {
                        return Err(at(
                            n,
                            format!(
                                "unknown format `{}` (expected ascii, binary_little_endian \
                                 or binary_big_endian)",
                                other.unwrap_or_default()
                            ),
                        ))
                    }
                });
                let version = words.next().and_then(|v| v.parse::<f64>().ok());
                if version != Some(1.0) {
                    return Err(at(n, "unsupported PLY version (expected 1.0)".into()));
                }
            }
            "element" => {
                let (Some(name), Some(count)) = (words.next(), words.next()) else {
                    return Err(at(n, "expected `element NAME COUNT`".into()));
                };
                let count = count
                    .parse::<u64>()
                    .map_err(|_| at(n, format!("element {name}: `{count}` is not a count")))?;
                if elements.iter().any(|e| e.name == name) {
                    return Err(at(n, format!("second `element {name}`")));
                }
                elements.push(Element {
                    name: name.to_owned(),
                    count,
                    properties: Vec::new(),
                    line: n,
                });
            }
            "property" => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| at(n, "`property` before any `element`".into()))?;
                let property = parse_property(&mut words).map_err(|m| at(n, m))?;
                element.properties.push(property);
            }
            "end_header" => {
                let format = format.ok_or_else(|| at(n, "header has no `format` line".into()))?;
                return Ok(Header {
                    format,
                    elements,
                    body_start: lines.offset(),
                    end_line: n,
                });
            }
            // Blender 2.47's exporter wrote its description line without the
            // `comment` keyword (assimp's Wuson.ply). Before the first
            // element such a line cannot change the layout, so let it pass.
            _ if elements.is_empty() => {}
            _ => {
                return Err(at(
                    n,
                    format!("unknown header keyword `{}`", show(keyword.as_bytes())),
                ))
            }
        }
    }
    Err(at(
        lines.number(),
        "file ends inside the header (no `end_header` line)".into(),
    ))
}

/// `TYPE NAME` or `list COUNT_TYPE ITEM_TYPE NAME`, after `property`.
fn parse_property<'a>(words: &mut impl Iterator<Item = &'a str>) -> Result<Property, String> {
    let scalar = |name: Option<&str>| {
        let name = name.ok_or("incomplete `property` line")?;
        Scalar::from_name(name)
            .ok_or_else(|| format!("unknown property type `{}`", show(name.as_bytes())))
    };
    let first = words.next();
    let kind = if first == Some("list") {
        let count = scalar(words.next())?;
        let item = scalar(words.next())?;
        if count.integer_range().is_none() {
            return Err(format!(
                "a list count must have an integer type, not {}",
                count.name()
            ));
        }
        Kind::List { count, item }
    } else {
        Kind::Scalar(scalar(first)?)
    };
    let name = words.next().ok_or("`property` line without a name")?;
    Ok(Property {
        name: name.to_owned(),
        kind,
    })
}

/// What each property of the vertex and face elements is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Role {
    /// Coordinate 0..3 of the position, or 3..6 for the normal.
    Coordinate(usize),
    VertexIndices,
    Ignored,
}

/// Where the wanted values sit in the elements of a header.
#[derive(Debug)]
pub(super) struct Layout {
    /// Index of the vertex element.
    pub(super) vertex: usize,
    /// The role of each vertex property.
    pub(super) vertex_roles: Vec<Role>,
    /// Whether nx, ny and nz are all there.
    pub(super) has_normals: bool,
    /// Index of the face element and the role of each of its properties,
    /// when there is one with properties.
    pub(super) face: Option<(usize, Vec<Role>)>,
}

impl Layout {
    /// Find the wanted properties; errors name the declaring line.
    pub(super) fn of(header: &Header, path: &Path) -> Result<Layout, InputError> {
        let find = |name: &str| header.elements.iter().position(|e| e.name == name);
        let vertex = find("vertex").ok_or_else(|| {
            InputError::line(path, header.end_line, "header declares no `element vertex`")
        })?;
        let element = &header.elements[vertex];
        let scalar_named = |name: &str| {
            element
                .properties
                .iter()
                .position(|p| p.name == name && matches!(p.kind, Kind::Scalar(_)))
        };
        let mut vertex_roles = vec![Role::Ignored; element.properties.len()];
        for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
            let p = scalar_named(name).ok_or_else(|| {
                InputError::line(
                    path,
                    element.line,
                    format!("element vertex has no scalar property `{name}`"),
                )
            })?;
            vertex_roles[p] = Role::Coordinate(axis);
        }
        let normal: Vec<usize> = ["nx", "ny", "nz"]
            .into_iter()
            .filter_map(scalar_named)
            .collect();
        let has_normals = normal.len() == 3;
        if has_normals {
            for (axis, p) in normal.into_iter().enumerate() {
                vertex_roles[p] = Role::Coordinate(3 + axis);
            }
        }

        let face = match find("face") {
            Some(f) if !header.elements[f].properties.is_empty() => {
                let element = &header.elements[f];
                let indices = element
                    .properties
                    .iter()
                    .position(|p| {
                        (p.name == "vertex_indices" || p.name == "vertex_index")
                            && matches!(p.kind, Kind::List { .. })
                    })
                    .ok_or_else(|| {
                        InputError::line(
                            path,
                            element.line,
                            "element face has no list property `vertex_indices`",
                        )
                    })?;
                let mut roles = vec![Role::Ignored; element.properties.len()];
                roles[indices] = Role::VertexIndices;
                Some((f, roles))
            }
            _ => None,
        };
        Ok(Layout {
            vertex,
            vertex_roles,
            has_normals,
            face,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{ascii, parse, XYZ};
    use crate::io::Place;

    #[test]
    fn header_errors_name_the_line() {
        for (text, line, needle) in [
            ("plx\n".to_string(), 1, "not a PLY file"),
            (
                "ply\nformat utf8 1.0\nend_header\n".into(),
                2,
                "unknown format",
            ),
            ("ply\nformat ascii 2.0\nend_header\n".into(), 2, "version"),
            (
                "ply\nformat ascii 1.0\nproperty float x\n".into(),
                3,
                "before any",
            ),
            (
                ascii("element vertex 3\nproperty list float int x\n", ""),
                4,
                "integer type",
            ),
            (ascii("element vertex 3\nproperty float x\n", ""), 3, "`y`"),
            (
                ascii(&format!("element vertex 3\n{XYZ}bogus\n"), ""),
                7,
                "unknown header keyword",
            ),
            (
                ascii(&format!("element vertex 5000000000\n{XYZ}"), ""),
                3,
                "32-bit",
            ),
            (
                ascii(
                    &format!(
                        "element vertex 3\n{XYZ}element face 1\nproperty int vertex_indices\n"
                    ),
                    "",
                ),
                7,
                "vertex_indices",
            ),
        ] {
            let e = parse(&text).unwrap_err();
            assert_eq!(e.place, Place::Line(line), "{e}");
            assert!(e.message.contains(needle), "{e}");
        }
    }
}
