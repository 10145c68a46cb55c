//! OBJ reader (Wavefront), built on the tobj crate with triangulation and a
//! single index per vertex. All objects and groups of the file are merged
//! into one mesh.
//!
//! tobj reports errors without a line and, for some malformed indices,
//! can overflow integer arithmetic (index 0 wraps round to the largest
//! index). So a first pass of ours checks, line by line, what can go wrong —
//! vertices that are not three finite numbers, face indices that are zero
//! or out of range, faces with fewer than three vertices — and names the
//! line; only a file that passes goes to tobj.
//!
//! Materials are not read: `mtllib` and `usemtl` are passed over, and
//! polylines (`l`) and points (`p`) are not surfaces, so they are left out.

use super::{
    check_not_empty, finish, finite_vertex, parse_word, read_file, show, vertex_problem, words,
    Lines, MeshData,
};
use crate::io::InputError;
use glam::Vec3;
use std::borrow::Cow;
use std::path::Path;

/// Read an OBJ file. Material libraries (`mtllib`) are not opened.
pub fn read_obj(path: &Path) -> Result<MeshData, InputError> {
    let bytes = read_file(path)?;
    parse_obj(&bytes, path)
}

/// Parse the bytes of an OBJ file; `path` only names the file in errors.
pub fn parse_obj(bytes: &[u8], path: &Path) -> Result<MeshData, InputError> {
    check_not_empty(bytes, path)?;
    if bytes.starts_with(&[0xFE, 0xFF]) || bytes.starts_with(&[0xFF, 0xFE]) {
        return Err(InputError::line(
            path,
            1,
            "UTF-16 text is not supported; convert the file to UTF-8",
        ));
    }
    // A UTF-8 byte-order mark would glue itself to the first keyword.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    // tobj stops at the first line that is not UTF-8, yet real files carry
    // Latin-1 in comments and material names (assimp's regr01.obj); numbers
    // are ASCII, so replacing such bytes loses nothing we read.
    let text = match String::from_utf8_lossy(bytes) {
        Cow::Borrowed(text) => Cow::Borrowed(text.as_bytes()),
        Cow::Owned(text) => Cow::Owned(text.into_bytes()),
    };
    let ignored = check(&text, path)?;
    let text = comment_out(text, &ignored);

    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // No material library is ever asked for: the statements are comments now.
    let (models, _) = tobj::load_obj_buf(&mut &text[..], &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| InputError::file(path, format!("cannot read OBJ: {e}")))?;

    let with_normals = models
        .iter()
        .all(|m| !m.mesh.normals.is_empty() && m.mesh.normals.len() == m.mesh.positions.len());
    let mut mesh = MeshData::default();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len();
        let count = m.positions.len() / 3;
        // Every merged index must fit in u32; then so does the offset.
        if u32::try_from(base + count).is_err() {
            return Err(InputError::file(
                path,
                "more vertices than 32-bit indices can address",
            ));
        }
        let offset = base as u32;
        for (i, p) in m.positions.chunks_exact(3).enumerate() {
            // Checked line by line already; this guards the merged result.
            let p = finite_vertex(base + i, Vec3::new(p[0], p[1], p[2]))
                .map_err(|msg| InputError::file(path, msg))?;
            mesh.positions.push(p);
        }
        if with_normals {
            mesh.normals.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|n| Vec3::new(n[0], n[1], n[2])),
            );
        }
        for t in m.indices.chunks_exact(3) {
            let triangle = [t[0], t[1], t[2]];
            if let Some(&bad) = triangle.iter().find(|&&v| v as usize >= count) {
                return Err(InputError::file(
                    path,
                    format!(
                        "object `{}`: vertex index {bad} out of range ({count} vertices)",
                        model.name
                    ),
                ));
            }
            mesh.triangles.push(triangle.map(|v| v + offset));
        }
    }
    finish(path, mesh)
}

/// Counts of the vertex data defined so far, which face indices refer to.
#[derive(Default)]
struct Counts {
    positions: u64,
    texcoords: u64,
    normals: u64,
}

/// Check the file line by line (see the module notes) and return the byte
/// offsets of statements tobj must not see: polylines (`l`), which tobj
/// turns into polygons when they have three or more points, and material
/// statements (`mtllib`, `usemtl`), which we do not need and on which tobj
/// fails when a name is empty (assimp's empty_mat.obj).
fn check(bytes: &[u8], path: &Path) -> Result<Vec<usize>, InputError> {
    let mut counts = Counts::default();
    let mut ignored = Vec::new();
    for line in Lines::new(bytes) {
        let at = |message: String| InputError::line(path, line.number, message);
        let mut values = words(line.bytes);
        let Some(keyword) = values.next() else {
            continue;
        };
        let indent = line.bytes.len() - line.bytes.trim_ascii_start().len();
        match keyword {
            b"v" => {
                check_position(values).map_err(at)?;
                counts.positions += 1;
            }
            b"vt" => counts.texcoords += 1,
            b"vn" => counts.normals += 1,
            b"f" => {
                let n = check_indices(values, &counts).map_err(at)?;
                if n < 3 {
                    return Err(at(format!(
                        "face has {n} vertices; a face needs at least 3"
                    )));
                }
            }
            b"l" => {
                check_indices(values, &counts).map_err(at)?;
                ignored.push(line.start + indent);
            }
            b"mtllib" | b"usemtl" => ignored.push(line.start + indent),
            _ => {}
        }
    }
    Ok(ignored)
}

/// `text` with a `#` written over the first byte of each statement at
/// `offsets`, turning it into a comment.
fn comment_out<'a>(text: Cow<'a, [u8]>, offsets: &[usize]) -> Cow<'a, [u8]> {
    if offsets.is_empty() {
        return text;
    }
    let mut text = text.into_owned();
    for &offset in offsets {
        if let Some(b) = text.get_mut(offset) {
            *b = b'#';
        }
    }
    Cow::Owned(text)
}

/// A `v` line: `x y z`, `x y z w` or `x y z r g b`, all finite, w not 0.
fn check_position<'a>(values: impl Iterator<Item = &'a [u8]>) -> Result<(), String> {
    let numbers = values
        .map(|w| {
            parse_word::<f32>(w).ok_or_else(|| format!("vertex: `{}` is not a number", show(w)))
        })
        .collect::<Result<Vec<f32>, String>>()?;
    let p = match numbers[..] {
        [x, y, z] | [x, y, z, _, _, _] => Vec3::new(x, y, z),
        [x, y, z, w] if w != 0.0 => Vec3::new(x, y, z) / w,
        [_, _, _, _] => return Err("vertex has weight w = 0".into()),
        _ => {
            return Err(format!(
                "vertex: expected 3, 4 (x y z w) or 6 (x y z r g b) numbers, found {}",
                numbers.len()
            ))
        }
    };
    vertex_problem(p).map_or(Ok(()), |why| Err(format!("vertex {why}")))
}

/// Check the `v`, `v/vt`, `v//vn` or `v/vt/vn` references of an `f` or `l`
/// line against what is defined so far; returns how many there are.
/// Positive indices count from 1 at the start of the file, negative ones
/// back from the latest definition.
fn check_indices<'a>(
    values: impl Iterator<Item = &'a [u8]>,
    counts: &Counts,
) -> Result<usize, String> {
    let mut n = 0;
    for vertex in values {
        let limits = [
            ("vertex", counts.positions),
            ("texture coordinate", counts.texcoords),
            ("normal", counts.normals),
        ];
        let mut parts = vertex.split(|&b| b == b'/');
        for (kind, defined) in limits {
            let Some(part) = parts.next() else { break };
            if part.is_empty() && kind != "vertex" {
                continue; // `v//vn` leaves the texture coordinate out
            }
            let index: i64 = parse_word(part)
                .ok_or_else(|| format!("`{}` is not a vertex reference", show(vertex)))?;
            // 1..=defined forwards, -1..=-defined backwards; 0 is no index.
            if index == 0 || index.unsigned_abs() > defined {
                return Err(format!(
                    "{kind} index {index} out of range ({defined} defined so far; \
                     OBJ indices start at 1, negative ones count back)"
                ));
            }
        }
        if parts.next().is_some() {
            return Err(format!("`{}` is not a vertex reference", show(vertex)));
        }
        n += 1;
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<MeshData, InputError> {
        parse_obj(text.as_bytes(), Path::new("t.obj"))
    }

    #[test]
    fn two_objects_merge_with_offset_indices() {
        let mesh = parse(
            "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\nf -4 -3 -1 -2\n",
        )
        .unwrap();
        assert_eq!(mesh.positions.len(), 7);
        assert_eq!(mesh.triangles.len(), 3);
        assert!(mesh.triangles.iter().flatten().all(|&v| v < 7));
        assert!(mesh.triangles[1..].iter().flatten().all(|&v| v >= 3));
    }

    #[test]
    fn polylines_are_not_faces() {
        let e = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n").unwrap_err();
        assert_eq!(e.message, "no triangles");
    }

    #[test]
    fn bad_references_name_the_line() {
        for (text, needle) in [
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "out of range"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "out of range"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/5 2/5 3/5\n",
                "texture coordinate",
            ),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "at least 3"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -9223372036854775808 1 2\n",
                "out of range",
            ),
        ] {
            let e = parse(text).unwrap_err();
            assert_eq!(e.place, crate::io::Place::Line(4), "{text}");
            assert!(e.message.contains(needle), "{e}");
        }
        let e = parse("v 0 0 0\nv inf 0 0\n").unwrap_err();
        assert_eq!(e.place, crate::io::Place::Line(2));
    }
}
