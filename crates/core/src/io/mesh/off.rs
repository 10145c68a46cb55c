//! OFF reader (Geomview's Object File Format, the format of the CGAL data
//! sets). Text, one vertex or face per line:
//!
//! ```text
//! [ST][C][N]OFF [nv nf ne]     header keyword, counts may follow on the same line
//! nv nf ne                     vertex, face and edge counts (edges ignored)
//! x y z [nx ny nz] [colour] …  nv vertex lines; NOFF adds a normal
//! n i0 i1 … i(n-1) [colour]    nf face lines, polygons split into fans
//! ```
//!
//! `#` starts a comment; blank lines are skipped. Extra values on a line
//! (colours, texture coordinates) are ignored. Geomview lets the header
//! keyword be left out, so a file may start with the counts.
//! Reference: the Geomview manual, section "OFF Files".

use super::{
    bounded_capacity, check_not_empty, finish, finite_vertex, parse_word, push_fan, read_file,
    show, vertex_count_u32, words, Line, Lines, MeshData,
};
use crate::io::InputError;
use glam::Vec3;
use std::path::Path;

/// Fewest bytes a vertex line can take (`0 0 0` and a line end) and a face
/// line (a count and a line end; such a face is refused later, with a
/// better message than a size check could give): bounds on how many of
/// each the rest of the file can hold.
const MIN_VERTEX_LINE: usize = 6;
const MIN_FACE_LINE: usize = 2;

/// Read an OFF file.
pub fn read_off(path: &Path) -> Result<MeshData, InputError> {
    let bytes = read_file(path)?;
    parse_off(&bytes, path)
}

/// Parse the bytes of an OFF file; `path` only names the file in errors.
pub fn parse_off(bytes: &[u8], path: &Path) -> Result<MeshData, InputError> {
    check_not_empty(bytes, path)?;
    let mut lines = Lines::new(bytes);
    let at = |line: usize, message: String| InputError::line(path, line, message);

    let first = next_content(&mut lines)
        .ok_or_else(|| InputError::file(path, "no content (only comments or blank lines)"))?;
    let mut first_words = words(first.bytes);
    let keyword = first_words.next().unwrap_or_default();
    let (has_normals, counts_line) = if parse_word::<u64>(keyword).is_some() {
        // No header keyword: this line already holds the counts.
        (false, first)
    } else {
        let has_normals = parse_keyword(keyword).map_err(|m| at(first.number, m))?;
        match first_words.next() {
            Some(w) if w.eq_ignore_ascii_case(b"BINARY") => {
                return Err(at(first.number, "binary OFF is not supported".into()))
            }
            // Counts on the header line, after the keyword.
            Some(_) => (has_normals, strip_first_word(first)),
            None => {
                let counts = next_content(&mut lines).ok_or_else(|| {
                    at(
                        first.number,
                        "file ends before the counts line `nv nf ne`".into(),
                    )
                })?;
                (has_normals, counts)
            }
        }
    };

    let (nv, nf) = parse_counts(counts_line).map_err(|m| at(counts_line.number, m))?;
    let remaining = bytes.len() - lines.offset();
    let needed = nv
        .saturating_mul(MIN_VERTEX_LINE as u64)
        .saturating_add(nf.saturating_mul(MIN_FACE_LINE as u64));
    // The last line may lack its line end, hence the + 1.
    if needed > remaining as u64 + 1 {
        return Err(at(
            counts_line.number,
            format!(
                "the counts line declares {nv} vertices and {nf} faces, \
                 more than the {remaining} bytes after it can hold"
            ),
        ));
    }
    let vertex_count = vertex_count_u32(nv).map_err(|m| at(counts_line.number, m))?;

    let values_per_vertex = if has_normals { 6 } else { 3 };
    let mut mesh = MeshData {
        positions: Vec::with_capacity(bounded_capacity(nv, remaining, MIN_VERTEX_LINE)),
        ..MeshData::default()
    };
    let mut values = [0.0f32; 6];
    for i in 0..nv {
        let line = next_content(&mut lines).ok_or_else(|| {
            at(
                lines.number(),
                format!("file ends after {i} of {nv} vertices"),
            )
        })?;
        let mut found = 0;
        for (slot, word) in values
            .iter_mut()
            .zip(words(line.bytes))
            .take(values_per_vertex)
        {
            *slot = parse_word(word).ok_or_else(|| {
                at(
                    line.number,
                    format!("vertex {i}: `{}` is not a number", show(word)),
                )
            })?;
            found += 1;
        }
        if found < values_per_vertex {
            return Err(at(
                line.number,
                format!("vertex {i}: expected {values_per_vertex} numbers, found {found}"),
            ));
        }
        let p = finite_vertex(i as usize, Vec3::new(values[0], values[1], values[2]))
            .map_err(|m| at(line.number, m))?;
        mesh.positions.push(p);
        if has_normals {
            mesh.normals
                .push(Vec3::new(values[3], values[4], values[5]));
        }
    }

    let remaining = bytes.len() - lines.offset();
    mesh.triangles = Vec::with_capacity(bounded_capacity(nf, remaining, MIN_FACE_LINE));
    let mut polygon = Vec::new();
    for j in 0..nf {
        let line = next_content(&mut lines)
            .ok_or_else(|| at(lines.number(), format!("file ends after {j} of {nf} faces")))?;
        read_face(line.bytes, j, vertex_count, &mut polygon).map_err(|m| at(line.number, m))?;
        push_fan(&mut mesh.triangles, &polygon);
    }
    // Whatever follows the faces (edges, in some writers) is not needed.
    finish(path, mesh)
}

/// The next line with content, its comment removed; `None` at the end.
fn next_content<'a>(lines: &mut Lines<'a>) -> Option<Line<'a>> {
    lines.find_map(|mut line| {
        if let Some(hash) = line.bytes.iter().position(|&b| b == b'#') {
            line.bytes = &line.bytes[..hash];
        }
        words(line.bytes).next().is_some().then_some(line)
    })
}

/// The line without its first word.
fn strip_first_word(mut line: Line<'_>) -> Line<'_> {
    let bytes = line.bytes.trim_ascii_start();
    let end = bytes
        .iter()
        .position(u8::is_ascii_whitespace)
        .unwrap_or(bytes.len());
    line.bytes = &bytes[end..];
    line
}

/// Whether the header keyword `[ST][C][N]OFF` announces normals. `4OFF`
/// (four-dimensional) and `nOFF` (any dimension) are refused.
fn parse_keyword(keyword: &[u8]) -> Result<bool, String> {
    let not_off = || {
        format!(
            "not an OFF file: expected a header like `OFF`, `COFF`, `NOFF` or `CNOFF`, found `{}`",
            show(keyword)
        )
    };
    let prefix = keyword.strip_suffix(b"OFF").ok_or_else(not_off)?;
    let prefix = prefix
        .strip_prefix(b"ST")
        .or_else(|| prefix.strip_suffix(b"ST"))
        .unwrap_or(prefix);
    let mut has_normals = false;
    let mut has_colours = false;
    for &letter in prefix {
        match letter {
            b'N' if !has_normals => has_normals = true,
            b'C' if !has_colours => has_colours = true,
            b'4' | b'n' => {
                return Err(format!(
                    "`{}`: only three-dimensional OFF is supported",
                    show(keyword)
                ))
            }
            _ => return Err(not_off()),
        }
    }
    Ok(has_normals)
}

/// The vertex and face counts of the counts line `nv nf [ne]`.
fn parse_counts(line: Line<'_>) -> Result<(u64, u64), String> {
    let mut counts = words(line.bytes).map(|w| {
        parse_word::<u64>(w).ok_or_else(|| {
            format!(
                "counts line: `{}` is not a count (expected `nv nf ne`)",
                show(w)
            )
        })
    });
    let nv = counts.next().transpose()?;
    let nf = counts.next().transpose()?;
    match (nv, nf) {
        (Some(nv), Some(nf)) => Ok((nv, nf)),
        _ => Err("counts line: expected `nv nf ne` (vertex, face and edge counts)".into()),
    }
}

/// Parse face `index` from its line `n i0 … i(n-1) [colour]` into `polygon`.
fn read_face(
    line: &[u8],
    index: u64,
    vertex_count: u32,
    polygon: &mut Vec<u32>,
) -> Result<(), String> {
    let mut values = words(line);
    let n_word = values.next().unwrap_or_default();
    let n: u64 = parse_word(n_word)
        .ok_or_else(|| format!("face {index}: `{}` is not a vertex count", show(n_word)))?;
    if n < 3 {
        return Err(format!(
            "face {index} has {n} vertices; a face needs at least 3"
        ));
    }
    polygon.clear();
    for word in values.by_ref() {
        if polygon.len() as u64 == n {
            break; // what follows is a colour
        }
        let v: u64 = parse_word(word)
            .ok_or_else(|| format!("face {index}: `{}` is not a vertex index", show(word)))?;
        if v >= u64::from(vertex_count) {
            return Err(format!(
                "face {index}: vertex index {v} out of range (the file has {vertex_count} vertices)"
            ));
        }
        polygon.push(v as u32);
    }
    if (polygon.len() as u64) < n {
        return Err(format!(
            "face {index}: expected {n} vertex indices, found {}",
            polygon.len()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<MeshData, InputError> {
        parse_off(text.as_bytes(), Path::new("t.off"))
    }

    #[test]
    fn quad_with_comments_and_counts_on_header_line() {
        let mesh =
            parse("# a quad\nOFF 4 1 0\n\n0 0 0\n1 0 0 # x\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n")
                .unwrap();
        assert_eq!(mesh.positions.len(), 4);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn noff_gives_unit_normals() {
        let mesh = parse("NOFF\n3 1 0\n0 0 0 0 0 2\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n").unwrap();
        assert_eq!(mesh.normals, vec![Vec3::Z; 3]);
    }

    #[test]
    fn keyword_variants() {
        assert_eq!(parse_keyword(b"OFF"), Ok(false));
        assert_eq!(parse_keyword(b"COFF"), Ok(false));
        assert_eq!(parse_keyword(b"CNOFF"), Ok(true));
        assert_eq!(parse_keyword(b"NCOFF"), Ok(true));
        assert_eq!(parse_keyword(b"STCOFF"), Ok(false));
        assert!(parse_keyword(b"4OFF").is_err());
        assert!(parse_keyword(b"PLY").is_err());
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n").unwrap_err();
        assert_eq!(e.place, crate::io::Place::Line(6));
        assert!(e.message.contains("out of range"), "{e}");
        let e = parse("OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n").unwrap_err();
        assert_eq!(e.place, crate::io::Place::Line(4));
        let e = parse("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n").unwrap_err();
        assert!(e.message.contains("at least 3"), "{e}");
    }
}
