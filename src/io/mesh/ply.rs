//! PLY reader (the Stanford polygon format), ASCII and binary in either byte
//! order. A text header declares elements and their properties; the body
//! holds the elements in that order:
//!
//! ```text
//! ply
//! format ascii 1.0            (or binary_little_endian / binary_big_endian)
//! comment …                   (and obj_info …)
//! element vertex 8
//! property float x            (y, z; nx, ny, nz give normals)
//! element face 6
//! property list uchar int vertex_indices
//! end_header
//! ```
//!
//! We read `vertex` x, y, z (and nx, ny, nz when all three are present) and
//! the `face` list `vertex_indices` (or `vertex_index`), splitting polygons
//! into fans; every other element and property is read past. The reader is
//! written here rather than taken from the ply-rs crate, which is no longer
//! maintained. Reference: Greg Turk, "The PLY Polygon File Format" (1994).

use super::{
    bounded_capacity, check_not_empty, finish, finite_vertex, push_fan, read_file, show,
    vertex_count_u32, Lines, MeshData,
};
use crate::io::{InputError, Place};
use glam::Vec3;
use std::path::Path;

/// Read a PLY file.
pub fn read_ply(path: &Path) -> Result<MeshData, InputError> {
    let bytes = read_file(path)?;
    parse_ply(&bytes, path)
}

/// Parse the bytes of a PLY file; `path` only names the file in errors.
pub fn parse_ply(bytes: &[u8], path: &Path) -> Result<MeshData, InputError> {
    check_not_empty(bytes, path)?;
    let header = parse_header(bytes, path)?;
    let layout = Layout::of(&header, path)?;
    let body = bytes.get(header.body_start..).unwrap_or_default();
    match header.format {
        Format::Ascii => {
            let reader = AsciiBody {
                path,
                data: body,
                pos: 0,
                line: header.end_line + 1,
                last_line: header.end_line,
            };
            read_body(reader, &header, &layout, path)
        }
        Format::BinaryLittleEndian | Format::BinaryBigEndian => {
            let reader = BinaryBody {
                path,
                data: bytes,
                pos: header.body_start,
                big_endian: header.format == Format::BinaryBigEndian,
            };
            read_body(reader, &header, &layout, path)
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

/// The scalar types of PLY, under their old and their sized names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
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
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The range of an integer type, `None` for floating point.
    fn integer_range(self) -> Option<(i64, i64)> {
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

    fn name(self) -> &'static str {
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

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
    /// Header line that declared it, for errors about its layout.
    line: usize,
}

impl Element {
    /// Bytes one item takes at least: in binary, its scalars and list
    /// counts; in ASCII, one character and one separator per value.
    fn min_item_bytes(&self, format: Format) -> usize {
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
    fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => Some(s.size()),
                Kind::List { .. } => None,
            })
            .sum()
    }
}

#[derive(Debug)]
struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset where the body starts, just after `end_header`.
    body_start: usize,
    /// Line number of `end_header`.
    end_line: usize,
}

fn parse_header(bytes: &[u8], path: &Path) -> Result<Header, InputError> {
    let at = |line: usize, message: String| InputError::line(path, line, message);
    let mut lines = Lines::new(bytes);
    if !lines
        .next()
        .is_some_and(|first| first.bytes.trim_ascii() == b"ply")
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
enum Role {
    /// Coordinate 0..3 of the position, or 3..6 for the normal.
    Coordinate(usize),
    VertexIndices,
    Ignored,
}

/// Where the wanted values sit in the elements of a header.
#[derive(Debug)]
struct Layout {
    vertex: usize,
    vertex_roles: Vec<Role>,
    has_normals: bool,
    face: Option<(usize, Vec<Role>)>,
}

impl Layout {
    fn of(header: &Header, path: &Path) -> Result<Layout, InputError> {
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

/// Names an element item in messages: "vertex 57".
#[derive(Clone, Copy)]
struct Item<'a> {
    element: &'a str,
    index: u64,
}

impl std::fmt::Display for Item<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.element, self.index)
    }
}

/// The two encodings of a PLY body, read value by value.
trait Body {
    /// The file, for errors.
    fn path(&self) -> &Path;
    /// Bytes left to read.
    fn remaining(&self) -> usize;
    /// Where the next value starts.
    fn place(&mut self) -> Place;
    /// Called before each item; a binary body checks that a fixed-size item
    /// is all there, to name the whole item when the file is cut short.
    fn begin_item(&mut self, element: &Element, item: Item) -> Result<(), InputError>;
    /// One value of type `ty`, as f64 (which holds every PLY scalar exactly).
    fn scalar(&mut self, ty: Scalar, item: Item, property: &str) -> Result<f64, InputError>;
    /// Skip `n` values of type `ty`.
    fn skip(&mut self, ty: Scalar, n: usize, item: Item, property: &str) -> Result<(), InputError>;
    /// Skip a whole element whose values are not needed.
    fn skip_element(&mut self, element: &Element) -> Result<(), InputError> {
        for index in 0..element.count {
            let item = Item {
                element: &element.name,
                index,
            };
            self.begin_item(element, item)?;
            for p in &element.properties {
                skip_property(self, p, item)?;
            }
        }
        Ok(())
    }
}

fn list_len<B: Body + ?Sized>(
    body: &mut B,
    count: Scalar,
    item: Item,
    property: &str,
) -> Result<usize, InputError> {
    let place = body.place();
    let n = body.scalar(count, item, property)?;
    // Integer count types make n whole; only its sign needs checking.
    if n < 0.0 {
        return Err(InputError::new(
            body.path(),
            place,
            format!("{item}: list `{property}` has negative length {n}"),
        ));
    }
    Ok(n as usize)
}

fn skip_property<B: Body + ?Sized>(
    body: &mut B,
    p: &Property,
    item: Item,
) -> Result<(), InputError> {
    match p.kind {
        Kind::Scalar(ty) => body.skip(ty, 1, item, &p.name),
        Kind::List { count, item: ty } => {
            let n = list_len(body, count, item, &p.name)?;
            body.skip(ty, n, item, &p.name)
        }
    }
}

fn read_body<B: Body>(
    mut body: B,
    header: &Header,
    layout: &Layout,
    path: &Path,
) -> Result<MeshData, InputError> {
    let vertex_element = &header.elements[layout.vertex];
    let vertex_count = vertex_count_u32(vertex_element.count)
        .map_err(|m| InputError::line(path, vertex_element.line, m))?;
    let remaining = body.remaining();
    let mut mesh = MeshData::default();
    for (e, element) in header.elements.iter().enumerate() {
        // An element without properties holds no data, whatever its count;
        // leaving it out also keeps a huge count from spinning here.
        if element.properties.is_empty() {
            continue;
        }
        let capacity = bounded_capacity(
            element.count,
            remaining,
            element.min_item_bytes(header.format),
        );
        if e == layout.vertex {
            mesh.positions.reserve(capacity);
            if layout.has_normals {
                mesh.normals.reserve(capacity);
            }
            read_vertices(&mut body, element, &layout.vertex_roles, &mut mesh, path)?;
        } else if let Some((_, roles)) = layout.face.as_ref().filter(|(f, _)| *f == e) {
            mesh.triangles.reserve(capacity);
            read_faces(
                &mut body,
                element,
                roles,
                vertex_count,
                &mut mesh.triangles,
                path,
            )?;
        } else {
            body.skip_element(element)?;
        }
    }
    // Whatever follows the last element is not ours to judge.
    finish(path, mesh)
}

fn read_vertices<B: Body>(
    body: &mut B,
    element: &Element,
    roles: &[Role],
    mesh: &mut MeshData,
    path: &Path,
) -> Result<(), InputError> {
    let has_normals = roles.contains(&Role::Coordinate(3));
    let mut values = [0.0f32; 6];
    for index in 0..element.count {
        let item = Item {
            element: &element.name,
            index,
        };
        let place = body.place();
        body.begin_item(element, item)?;
        for (p, role) in element.properties.iter().zip(roles) {
            match (role, p.kind) {
                (Role::Coordinate(slot), Kind::Scalar(ty)) => {
                    // An f64 beyond f32 range becomes infinite and is
                    // rejected just below, as it should be.
                    values[*slot] = body.scalar(ty, item, &p.name)? as f32;
                }
                _ => skip_property(body, p, item)?,
            }
        }
        let position = finite_vertex(index as usize, Vec3::new(values[0], values[1], values[2]))
            .map_err(|m| InputError::new(path, place, m))?;
        mesh.positions.push(position);
        if has_normals {
            mesh.normals
                .push(Vec3::new(values[3], values[4], values[5]));
        }
    }
    Ok(())
}

fn read_faces<B: Body>(
    body: &mut B,
    element: &Element,
    roles: &[Role],
    vertex_count: u32,
    triangles: &mut Vec<[u32; 3]>,
    path: &Path,
) -> Result<(), InputError> {
    let mut polygon = Vec::new();
    for index in 0..element.count {
        let item = Item {
            element: &element.name,
            index,
        };
        body.begin_item(element, item)?;
        for (p, role) in element.properties.iter().zip(roles) {
            match (role, p.kind) {
                (Role::VertexIndices, Kind::List { count, item: ty }) => {
                    let place = body.place();
                    let n = list_len(body, count, item, &p.name)?;
                    if n < 3 {
                        return Err(InputError::new(
                            path,
                            place,
                            format!("{item} has {n} vertices; a face needs at least 3"),
                        ));
                    }
                    // Grows as values arrive: n is untrusted until read.
                    polygon.clear();
                    for _ in 0..n {
                        let v = body.scalar(ty, item, &p.name)?;
                        if !(v >= 0.0 && v < f64::from(vertex_count) && v.fract() == 0.0) {
                            return Err(InputError::new(
                                path,
                                place,
                                format!(
                                    "{item}: vertex index {v} out of range \
                                     (the file has {vertex_count} vertices)"
                                ),
                            ));
                        }
                        polygon.push(v as u32);
                    }
                    push_fan(triangles, &polygon);
                }
                _ => skip_property(body, p, item)?,
            }
        }
    }
    Ok(())
}

/// An ASCII body: whitespace-separated numbers, errors by line.
struct AsciiBody<'a> {
    path: &'a Path,
    data: &'a [u8],
    pos: usize,
    /// Line number at `pos`.
    line: usize,
    /// Line of the last value read, where "file ends" is reported: the
    /// line after the final line end would point at nothing.
    last_line: usize,
}

impl<'a> AsciiBody<'a> {
    fn skip_space(&mut self) {
        while let Some(&b) = self.data.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
    }

    fn word(&mut self, item: Item, property: &str) -> Result<&'a [u8], InputError> {
        self.skip_space();
        let rest = &self.data[self.pos.min(self.data.len())..];
        let len = rest
            .iter()
            .position(u8::is_ascii_whitespace)
            .unwrap_or(rest.len());
        if len == 0 {
            return Err(InputError::line(
                self.path,
                self.last_line,
                format!("file ends while reading `{property}` of {item}"),
            ));
        }
        self.pos += len;
        self.last_line = self.line;
        Ok(&rest[..len])
    }
}

impl Body for AsciiBody<'_> {
    fn path(&self) -> &Path {
        self.path
    }

    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    fn place(&mut self) -> Place {
        self.skip_space();
        Place::Line(self.line)
    }

    fn begin_item(&mut self, _: &Element, _: Item) -> Result<(), InputError> {
        Ok(())
    }

    fn scalar(&mut self, ty: Scalar, item: Item, property: &str) -> Result<f64, InputError> {
        let word = self.word(item, property)?;
        let line = self.line;
        let bad = |why: &str| {
            InputError::line(
                self.path,
                line,
                format!("{item}: `{property}` is `{}`, {why}", show(word)),
            )
        };
        let text = std::str::from_utf8(word).map_err(|_| bad("not a number"))?;
        match ty.integer_range() {
            Some((lo, hi)) => {
                let v: i64 = text
                    .parse()
                    .map_err(|_| bad(&format!("not an integer ({})", ty.name())))?;
                if !(lo..=hi).contains(&v) {
                    return Err(bad(&format!("out of the range of {}", ty.name())));
                }
                Ok(v as f64)
            }
            None => text.parse().map_err(|_| bad("not a number")),
        }
    }

    fn skip(&mut self, ty: Scalar, n: usize, item: Item, property: &str) -> Result<(), InputError> {
        for _ in 0..n {
            self.scalar(ty, item, property)?;
        }
        Ok(())
    }
}

/// A binary body, either byte order; errors by byte offset.
struct BinaryBody<'a> {
    path: &'a Path,
    /// The whole file, so offsets in errors are file offsets.
    data: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl<'a> BinaryBody<'a> {
    /// Check that `n` bytes of `what` are there at the current position.
    fn need(&self, n: usize, what: &dyn std::fmt::Display) -> Result<(), InputError> {
        if self.data.len() - self.pos < n {
            return Err(InputError::new(
                self.path,
                Place::Byte(self.pos as u64),
                format!(
                    "truncated: expected {n} bytes of {what} at byte {}, file ends at {}",
                    self.pos,
                    self.data.len()
                ),
            ));
        }
        Ok(())
    }

    fn take(&mut self, n: usize, what: &dyn std::fmt::Display) -> Result<&'a [u8], InputError> {
        self.need(n, what)?;
        let bytes = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(bytes)
    }
}

/// The first `N` bytes of `b` as an array; callers pass at least `N`.
fn array<const N: usize>(b: &[u8]) -> [u8; N] {
    let mut a = [0; N];
    a.copy_from_slice(&b[..N]);
    a
}

impl Body for BinaryBody<'_> {
    fn path(&self) -> &Path {
        self.path
    }

    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    fn place(&mut self) -> Place {
        Place::Byte(self.pos as u64)
    }

    fn begin_item(&mut self, element: &Element, item: Item) -> Result<(), InputError> {
        match element.fixed_size() {
            Some(size) => self.need(size, &item),
            None => Ok(()),
        }
    }

    fn scalar(&mut self, ty: Scalar, item: Item, _: &str) -> Result<f64, InputError> {
        let b = self.take(ty.size(), &item)?;
        let be = self.big_endian;
        Ok(match ty {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(if be {
                i16::from_be_bytes(array(b))
            } else {
                i16::from_le_bytes(array(b))
            }),
            Scalar::U16 => f64::from(if be {
                u16::from_be_bytes(array(b))
            } else {
                u16::from_le_bytes(array(b))
            }),
            Scalar::I32 => f64::from(if be {
                i32::from_be_bytes(array(b))
            } else {
                i32::from_le_bytes(array(b))
            }),
            Scalar::U32 => f64::from(if be {
                u32::from_be_bytes(array(b))
            } else {
                u32::from_le_bytes(array(b))
            }),
            Scalar::F32 => f64::from(if be {
                f32::from_be_bytes(array(b))
            } else {
                f32::from_le_bytes(array(b))
            }),
            Scalar::F64 => {
                if be {
                    f64::from_be_bytes(array(b))
                } else {
                    f64::from_le_bytes(array(b))
                }
            }
        })
    }

    fn skip(&mut self, ty: Scalar, n: usize, item: Item, _: &str) -> Result<(), InputError> {
        let bytes = n.saturating_mul(ty.size());
        self.take(bytes, &item).map(|_| ())
    }

    fn skip_element(&mut self, element: &Element) -> Result<(), InputError> {
        match element.fixed_size() {
            // One bounds check for the whole element rather than per item.
            Some(size) => {
                let total = usize::try_from(element.count)
                    .ok()
                    .and_then(|c| c.checked_mul(size))
                    .unwrap_or(usize::MAX);
                let what = format!("the {} {} elements", element.count, element.name);
                self.take(total, &what).map(|_| ())
            }
            None => {
                for index in 0..element.count {
                    let item = Item {
                        element: &element.name,
                        index,
                    };
                    for p in &element.properties {
                        skip_property(self, p, item)?;
                    }
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const XYZ: &str = "property float x\nproperty float y\nproperty float z\n";

    fn parse(text: &str) -> Result<MeshData, InputError> {
        parse_ply(text.as_bytes(), Path::new("t.ply"))
    }

    fn ascii(elements: &str, body: &str) -> String {
        format!("ply\nformat ascii 1.0\n{elements}end_header\n{body}")
    }

    #[test]
    fn reads_a_triangle_and_skips_other_elements() {
        let text = ascii(
            &format!("element material 1\nproperty list uchar float rgb\nelement vertex 3\n{XYZ}element face 1\nproperty list uchar int vertex_indices\n"),
            "3 0.1 0.2 0.3\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        );
        let mesh = parse(&text).unwrap();
        assert_eq!(mesh.positions[1], Vec3::X);
        assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn a_bare_description_line_before_the_elements_passes() {
        // As Blender 2.47 wrote it (assimp's Wuson.ply).
        let text = format!(
            "ply\nformat ascii 1.0\nCreated by Blender3D 247\nelement vertex 3\n{XYZ}element face 1\nproperty list uchar int vertex_index\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
        );
        assert_eq!(parse(&text).unwrap().triangles.len(), 1);
    }

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

    #[test]
    fn ascii_body_errors_name_the_line() {
        let header = format!(
            "element vertex 3\n{XYZ}element face 1\nproperty list uchar int vertex_indices\n"
        );
        for (body, line, needle) in [
            ("0 0 0\n1 0 0\n0 1\n", 12, "file ends"),
            ("0 0 0\n1 0 0\n0 x 0\n3 0 1 2\n", 12, "not a number"),
            ("0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n", 13, "range of uchar"),
            ("0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n", 13, "out of range"),
            ("0 0 0\n1 0 0\n0 1 0\n2 0 1\n", 13, "at least 3"),
        ] {
            let e = parse(&ascii(&header, body)).unwrap_err();
            assert_eq!(e.place, Place::Line(line), "{e}");
            assert!(e.message.contains(needle), "{e}");
        }
    }

    #[test]
    fn negative_binary_list_length_is_an_error() {
        let mut bytes = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex 3\n{XYZ}element face 1\nproperty list int int vertex_indices\nend_header\n"
        )
        .into_bytes();
        let body_start = bytes.len();
        bytes.extend([0u8; 36]);
        bytes.extend((-1i32).to_le_bytes());
        let e = parse_ply(&bytes, Path::new("t.ply")).unwrap_err();
        assert_eq!(e.place, Place::Byte(body_start as u64 + 36));
        assert!(e.message.contains("negative"), "{e}");
    }
}
