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
//!
//! Layout: [`header`] parses the header into elements and properties and
//! finds where the wanted values sit ([`header::Layout`]); this file reads
//! the body element by element through the [`Body`] trait, which the two
//! encodings implement: [`ascii`] (whitespace-separated numbers, errors by
//! line) and [`binary`] (either byte order, errors by byte offset).

mod ascii;
mod binary;
mod header;

use self::ascii::AsciiBody;
use self::binary::BinaryBody;
use self::header::{parse_header, Element, Format, Header, Kind, Layout, Property, Role, Scalar};
use super::{
    bounded_capacity, check_not_empty, finish, finite_vertex, push_fan, read_file,
    vertex_count_u32, MeshData,
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

/// The length of a list property, read from its count; a negative count
/// is an error naming the item and the property.
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

/// Read past one property of an item, a scalar or a whole list.
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

/// Read every element of the body: the vertices and faces into a mesh,
/// the other elements read past.
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

/// The positions (and normals) of the vertex element.
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

/// The faces, each split into a triangle fan after checking its indices.
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The three coordinate properties of a vertex element.
    pub(super) const XYZ: &str = "property float x\nproperty float y\nproperty float z\n";

    /// Parse `text` as the file `t.ply`.
    pub(super) fn parse(text: &str) -> Result<MeshData, InputError> {
        parse_ply(text.as_bytes(), Path::new("t.ply"))
    }

    /// An ASCII PLY file with the given element declarations and body.
    pub(super) fn ascii(elements: &str, body: &str) -> String {
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
}
