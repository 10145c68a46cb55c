//! Triangle-mesh readers: OBJ (via tobj), PLY (ASCII, binary little and big
//! endian), OFF and 3DS. Each returns a [`MeshData`] in the file's own
//! coordinates; the scene applies the object transform.
//!
//! Every reader checks what it reads and reports the first problem as an
//! [`InputError`] with the file name and a line (text formats) or byte
//! offset (binary formats): non-finite coordinates, face indices out of
//! range, faces with fewer than three vertices, truncated files, and counts
//! in a header that the rest of the file cannot hold. No reader allocates
//! from a count it has not first bounded by the size of the input, so a
//! hostile header cannot exhaust memory, and none panics on any input.

mod obj;
mod off;
mod ply;
mod three_ds;

pub use obj::{parse_obj, read_obj};
pub use off::{parse_off, read_off};
pub use ply::{parse_ply, read_ply};
pub use three_ds::{parse_3ds, read_3ds};

use super::InputError;
use crate::math::MAX_COORDINATE;
pub use crate::shape::MeshData;
use glam::Vec3;
use std::path::Path;

/// The file extensions [`read_mesh`] understands, in lower case.
pub const MESH_EXTENSIONS: [&str; 4] = ["obj", "ply", "off", "3ds"];

/// Read a mesh, choosing the format by the file extension (case-insensitive:
/// `.obj`, `.ply`, `.off`, `.3ds`).
pub fn read_mesh(path: &Path) -> Result<MeshData, InputError> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match extension.as_deref() {
        Some("obj") => read_obj(path),
        Some("ply") => read_ply(path),
        Some("off") => read_off(path),
        Some("3ds") => read_3ds(path),
        Some(other) => Err(InputError::file(
            path,
            format!(
                "unsupported mesh format `.{other}` (supported: {})",
                supported_list()
            ),
        )),
        None => Err(InputError::file(
            path,
            format!(
                "no file extension to tell the mesh format (supported: {})",
                supported_list()
            ),
        )),
    }
}

fn supported_list() -> String {
    MESH_EXTENSIONS
        .iter()
        .map(|e| format!(".{e}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The whole file, or an error naming it; an empty file is an error too,
/// since no format here has a meaningful empty form.
fn read_file(path: &Path) -> Result<Vec<u8>, InputError> {
    let bytes = super::input::read(path, super::input::InputKind::Mesh)?;
    check_not_empty(&bytes, path)?;
    Ok(bytes)
}

fn check_not_empty(bytes: &[u8], path: &Path) -> Result<(), InputError> {
    if bytes.is_empty() {
        Err(InputError::file(path, "empty file"))
    } else {
        Ok(())
    }
}

/// Append the fan `(v0, v[i], v[i+1])` of a polygon to `triangles`. The fan
/// is exact for convex polygons, which is what OFF and PLY writers emit; a
/// concave polygon would need ear clipping, which no file we read needs.
fn push_fan(triangles: &mut Vec<[u32; 3]>, polygon: &[u32]) {
    if let Some((&first, rest)) = polygon.split_first() {
        triangles.extend(rest.windows(2).map(|pair| [first, pair[0], pair[1]]));
    }
}

/// The last checks every reader shares: there must be triangles, and the
/// normals, when present, are made unit length — or dropped altogether when
/// one of them is zero or not finite, because a renderer cannot use a
/// partial set of normals.
fn finish(path: &Path, mut mesh: MeshData) -> Result<MeshData, InputError> {
    if mesh.triangles.is_empty() {
        return Err(InputError::file(path, "no triangles"));
    }
    if mesh.normals.len() != mesh.positions.len() {
        mesh.normals.clear();
    }
    for n in &mut mesh.normals {
        let length = n.length();
        if !(length.is_finite() && length > 0.0) {
            mesh.normals.clear();
            break;
        }
        *n /= length;
    }
    Ok(mesh)
}

/// A position, or an error message naming the vertex when a coordinate is
/// NaN, infinite or beyond [`MAX_COORDINATE`] (the caller adds the place).
fn finite_vertex(index: usize, p: Vec3) -> Result<Vec3, String> {
    vertex_problem(p).map_or(Ok(p), |why| Err(format!("vertex {index} {why}")))
}

/// What is wrong with a vertex at `p`, if anything: a coordinate NaN,
/// infinite, or beyond [`MAX_COORDINATE`].
fn vertex_problem(p: Vec3) -> Option<String> {
    let show = crate::math::ShowVec(p);
    if !p.is_finite() {
        return Some(format!("has a non-finite coordinate {show}"));
    }
    if p.abs().max_element() > MAX_COORDINATE {
        return Some(format!(
            "{show} lies beyond ±{MAX_COORDINATE:e}, the largest coordinate raylab's geometry \
             may have (its ray tests would overflow single precision)"
        ));
    }
    None
}

/// `count` as a vertex count that fits the `u32` indices of [`MeshData`].
fn vertex_count_u32(count: u64) -> Result<u32, String> {
    u32::try_from(count)
        .map_err(|_| format!("{count} vertices are more than 32-bit indices can address"))
}

/// How many items to reserve room for when a file declares `count` items:
/// never more than the `remaining` bytes could hold at `min_item_bytes`
/// each, so that a lying header cannot make us allocate gigabytes.
fn bounded_capacity(count: u64, remaining: usize, min_item_bytes: usize) -> usize {
    let fit = remaining / min_item_bytes.max(1);
    usize::try_from(count).map_or(fit, |c| c.min(fit))
}

/// One line of a text file: its 1-based number, the byte offset where it
/// starts, and its bytes without the line end.
#[derive(Clone, Copy, Debug)]
struct Line<'a> {
    number: usize,
    start: usize,
    bytes: &'a [u8],
}

/// The lines of a byte buffer. `\n` ends a line and a `\r` before it is
/// dropped, so Unix and Windows files read alike. Works on bytes, not
/// `str`, so a stray non-UTF-8 byte in a comment does not stop a reader.
struct Lines<'a> {
    data: &'a [u8],
    pos: usize,
    number: usize,
}

impl<'a> Lines<'a> {
    fn new(data: &'a [u8]) -> Self {
        Self {
            data,
            pos: 0,
            number: 0,
        }
    }

    /// Byte offset just after the last line returned.
    fn offset(&self) -> usize {
        self.pos
    }

    /// Number of the last line returned (0 before the first).
    fn number(&self) -> usize {
        self.number
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = Line<'a>;

    fn next(&mut self) -> Option<Line<'a>> {
        let rest = self.data.get(self.pos..).filter(|r| !r.is_empty())?;
        let (bytes, advance) = match rest.iter().position(|&b| b == b'\n') {
            Some(end) => (&rest[..end], end + 1),
            None => (rest, rest.len()),
        };
        let start = self.pos;
        self.pos += advance;
        self.number += 1;
        Some(Line {
            number: self.number,
            start,
            bytes: bytes.strip_suffix(b"\r").unwrap_or(bytes),
        })
    }
}

/// The whitespace-separated words of a line.
fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(u8::is_ascii_whitespace)
        .filter(|w| !w.is_empty())
}

/// A word from the file, shortened for an error message (a hostile file may
/// hold a megabyte-long "number").
fn show(word: &[u8]) -> String {
    const LIMIT: usize = 40;
    let text = String::from_utf8_lossy(&word[..word.len().min(LIMIT)]).into_owned();
    if word.len() > LIMIT {
        text + "…"
    } else {
        text
    }
}

fn parse_word<T: std::str::FromStr>(word: &[u8]) -> Option<T> {
    std::str::from_utf8(word).ok()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fan_of_a_quad_is_two_triangles() {
        let mut t = Vec::new();
        push_fan(&mut t, &[0, 1, 2, 3]);
        assert_eq!(t, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn finish_normalises_and_drops_bad_normals() {
        let path = Path::new("x.off");
        let mut mesh = MeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z * 2.0, Vec3::Z, Vec3::Z],
            triangles: vec![[0, 1, 2]],
        };
        let done = finish(path, mesh.clone()).unwrap();
        assert_eq!(done.normals[0], Vec3::Z);
        mesh.normals[1] = Vec3::ZERO;
        assert!(finish(path, mesh).unwrap().normals.is_empty());
    }

    #[test]
    fn unknown_extension_names_it() {
        let e = read_mesh(Path::new("model.stl")).unwrap_err();
        assert!(e.message.contains(".stl") && e.message.contains(".3ds"));
    }
}
