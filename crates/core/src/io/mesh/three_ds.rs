//! 3DS reader (Autodesk 3D Studio). A 3DS file is a tree of chunks, each a
//! little-endian `u16` id and a `u32` length that counts its own 6-byte
//! header. The meshes sit at
//!
//! ```text
//! 0x4D4D MAIN
//! └ 0x3D3D EDITOR
//!   └ 0x4000 OBJECT      name (NUL-terminated), then sub-chunks
//!     └ 0x4100 TRIMESH
//!       ├ 0x4110 VERTICES   u16 count, count × (x, y, z) f32
//!       └ 0x4120 FACES      u16 count, count × (3 × u16 index, u16 flags),
//!                           then sub-chunks (materials, smoothing groups)
//! ```
//!
//! Every object's vertices and faces are read and merged into one mesh;
//! every other chunk is skipped whole. Each chunk's length is checked
//! against its parent and the file before anything inside it is read.
//!
//! Coordinates are taken as stored. 3DS keeps vertices in world space; the
//! local axis matrix of each mesh (0x4160) only matters together with the
//! keyframer's animation tracks (0xB000), and we skip both.
//! Reference: the "3D Studio File Format" notes by Jeff Lewis and Martin
//! van Velsen, as also followed by lib3ds.

use super::{check_not_empty, finish, finite_vertex, read_file, MeshData};
use crate::io::{InputError, Place};
use glam::Vec3;
use std::path::Path;

const MAIN: u16 = 0x4D4D;
const EDITOR: u16 = 0x3D3D;
const OBJECT: u16 = 0x4000;
const TRIMESH: u16 = 0x4100;
const VERTICES: u16 = 0x4110;
const FACES: u16 = 0x4120;

const HEADER: usize = 6;

/// Read a 3DS file.
pub fn read_3ds(path: &Path) -> Result<MeshData, InputError> {
    let bytes = read_file(path)?;
    parse_3ds(&bytes, path)
}

/// Parse the bytes of a 3DS file; `path` only names the file in errors.
pub fn parse_3ds(bytes: &[u8], path: &Path) -> Result<MeshData, InputError> {
    check_not_empty(bytes, path)?;
    let file = Reader { data: bytes, path };
    // Check the id before the length, so that any other file is called
    // what it is rather than a 3DS file with a bad chunk.
    let id = file.u16_at(0).unwrap_or_default();
    if id != MAIN {
        return Err(file.error(
            0,
            format!("not a 3DS file: the first chunk is 0x{id:04X}, expected 0x{MAIN:04X}"),
        ));
    }
    let main = file
        .chunks(None, 0, bytes.len())
        .next_chunk()?
        .ok_or_else(|| file.error(0, "no chunks"))?;
    // Bytes after the main chunk are not part of the model; leave them be.
    let mut mesh = MeshData::default();
    let mut in_main = file.children(&main, main.data_start);
    while let Some(editor) = in_main.next_chunk()? {
        if editor.id != EDITOR {
            continue;
        }
        let mut in_editor = file.children(&editor, editor.data_start);
        while let Some(object) = in_editor.next_chunk()? {
            if object.id == OBJECT {
                file.read_object(&object, &mut mesh)?;
            }
        }
    }
    finish(path, mesh)
}

/// One chunk: its id, where its header starts and where its data ends.
#[derive(Clone, Copy, Debug)]
struct Chunk {
    id: u16,
    start: usize,
    data_start: usize,
    end: usize,
}

impl Chunk {
    fn describe(&self) -> String {
        format!("chunk 0x{:04X} at byte {}", self.id, self.start)
    }
}

/// The file being read, for slicing and for errors.
#[derive(Clone, Copy)]
struct Reader<'a> {
    data: &'a [u8],
    path: &'a Path,
}

/// The chunks between `pos` and `end`, all inside `parent` (or the file).
struct Chunks<'a> {
    file: Reader<'a>,
    parent: Option<Chunk>,
    pos: usize,
    end: usize,
}

impl Chunks<'_> {
    /// The next chunk, with its length checked against the parent and the
    /// file; `None` when the parent's data is used up.
    fn next_chunk(&mut self) -> Result<Option<Chunk>, InputError> {
        if self.pos >= self.end {
            return Ok(None);
        }
        let start = self.pos;
        let inside = || match self.parent {
            Some(p) => format!("the end of its parent {} (byte {})", p.describe(), p.end),
            None => format!("the end of the file (byte {})", self.end),
        };
        let header = self
            .file
            .data
            .get(start..start + HEADER)
            .filter(|_| start + HEADER <= self.end)
            .ok_or_else(|| {
                self.file.error(
                    start,
                    format!(
                        "truncated chunk header: only {} bytes before {}",
                        self.end - start,
                        inside()
                    ),
                )
            })?;
        let id = u16::from_le_bytes([header[0], header[1]]);
        let length = u32::from_le_bytes([header[2], header[3], header[4], header[5]]) as usize;
        if length < HEADER {
            return Err(self.file.error(
                start,
                format!("chunk 0x{id:04X} has length {length}, less than its own 6-byte header"),
            ));
        }
        if length > self.end - start {
            return Err(self.file.error(
                start,
                format!(
                    "chunk 0x{id:04X} is {length} bytes long and runs past {}",
                    inside()
                ),
            ));
        }
        self.pos = start + length;
        Ok(Some(Chunk {
            id,
            start,
            data_start: start + HEADER,
            end: start + length,
        }))
    }
}

impl<'a> Reader<'a> {
    fn error(&self, at: usize, message: impl Into<String>) -> InputError {
        InputError::new(self.path, Place::Byte(at as u64), message)
    }

    fn chunks(&self, parent: Option<Chunk>, pos: usize, end: usize) -> Chunks<'a> {
        Chunks {
            file: *self,
            parent,
            pos,
            end,
        }
    }

    /// The sub-chunks of `parent`, starting at `pos` (after any fixed data).
    fn children(&self, parent: &Chunk, pos: usize) -> Chunks<'a> {
        self.chunks(Some(*parent), pos, parent.end)
    }

    fn u16_at(&self, at: usize) -> Option<u16> {
        let b = self.data.get(at..at + 2)?;
        Some(u16::from_le_bytes([b[0], b[1]]))
    }

    fn f32_at(&self, at: usize) -> Option<f32> {
        let b = self.data.get(at..at + 4)?;
        Some(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// An OBJECT chunk: a name, then sub-chunks of which only TRIMESH is a
    /// mesh (others are lights and cameras).
    fn read_object(&self, object: &Chunk, mesh: &mut MeshData) -> Result<(), InputError> {
        let name_bytes = &self.data[object.data_start..object.end];
        let name_len = name_bytes
            .iter()
            .position(|&b| b == 0)
            .ok_or_else(|| self.error(object.data_start, "object name is not NUL-terminated"))?;
        let name = String::from_utf8_lossy(&name_bytes[..name_len]);
        let mut parts = self.children(object, object.data_start + name_len + 1);
        while let Some(part) = parts.next_chunk()? {
            if part.id == TRIMESH {
                self.read_trimesh(&part, &name, mesh)?;
            }
        }
        Ok(())
    }

    fn read_trimesh(
        &self,
        trimesh: &Chunk,
        name: &str,
        mesh: &mut MeshData,
    ) -> Result<(), InputError> {
        let base = mesh.positions.len();
        let mut vertices: Option<usize> = None;
        // (face index within its list, byte offset of the face, indices)
        let mut faces: Vec<(usize, usize, [u16; 3])> = Vec::new();
        let mut parts = self.children(trimesh, trimesh.data_start);
        while let Some(part) = parts.next_chunk()? {
            match part.id {
                VERTICES => {
                    if vertices.is_some() {
                        return Err(self.error(
                            part.start,
                            format!("object `{name}` has a second vertex list"),
                        ));
                    }
                    let count = self.list_count(&part, 12, "vertex")?;
                    mesh.positions.reserve(count);
                    for i in 0..count {
                        let at = part.data_start + 2 + 12 * i;
                        let xyz = [0, 4, 8].map(|o| self.f32_at(at + o).unwrap_or(f32::NAN));
                        let p = finite_vertex(i, Vec3::from(xyz))
                            .map_err(|m| self.error(at, format!("object `{name}`: {m}")))?;
                        mesh.positions.push(p);
                    }
                    vertices = Some(count);
                }
                FACES => {
                    let count = self.list_count(&part, 8, "face")?;
                    faces.reserve(count);
                    for i in 0..count {
                        let at = part.data_start + 2 + 8 * i;
                        let v = [0, 2, 4].map(|o| self.u16_at(at + o).unwrap_or(u16::MAX));
                        faces.push((i, at, v));
                    }
                    // Material groups and smoothing follow; only their
                    // lengths are checked.
                    let mut extras = self.children(&part, part.data_start + 2 + 8 * count);
                    while extras.next_chunk()?.is_some() {}
                }
                _ => {}
            }
        }
        let count = vertices.unwrap_or(0);
        // Every merged index must fit in u32; then so does the offset.
        if u32::try_from(base + count).is_err() {
            return Err(self.error(
                trimesh.start,
                "more vertices than 32-bit indices can address",
            ));
        }
        let offset = base as u32;
        mesh.triangles.reserve(faces.len());
        for (i, at, v) in faces {
            if let Some(&bad) = v.iter().find(|&&v| usize::from(v) >= count) {
                return Err(self.error(
                    at,
                    format!(
                        "object `{name}`: face {i}: vertex index {bad} out of range \
                         (the object has {count} vertices)"
                    ),
                ));
            }
            mesh.triangles.push(v.map(|v| offset + u32::from(v)));
        }
        Ok(())
    }

    /// The `u16` count at the start of a vertex or face list, checked
    /// against the bytes the chunk holds (`size` bytes per entry).
    fn list_count(&self, chunk: &Chunk, size: usize, what: &str) -> Result<usize, InputError> {
        let count = self
            .u16_at(chunk.data_start)
            .filter(|_| chunk.data_start + 2 <= chunk.end)
            .ok_or_else(|| self.error(chunk.data_start, format!("{what} list has no count")))?;
        let count = usize::from(count);
        let available = chunk.end - chunk.data_start - 2;
        if count * size > available {
            return Err(self.error(
                chunk.data_start,
                format!(
                    "{what} list declares {count} entries ({} bytes) but its chunk holds {available}",
                    count * size
                ),
            ));
        }
        Ok(count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chunk with its header.
    fn chunk(id: u16, body: &[u8]) -> Vec<u8> {
        let mut c = id.to_le_bytes().to_vec();
        c.extend(((body.len() + 6) as u32).to_le_bytes());
        c.extend(body);
        c
    }

    fn triangle_file(index: u16) -> Vec<u8> {
        let mut verts = 3u16.to_le_bytes().to_vec();
        for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in v {
                verts.extend(c.to_le_bytes());
            }
        }
        let mut faces = 1u16.to_le_bytes().to_vec();
        for i in [0u16, 1, index, 0] {
            faces.extend(i.to_le_bytes());
        }
        let trimesh = [chunk(VERTICES, &verts), chunk(FACES, &faces)].concat();
        let object = [b"tri\0".to_vec(), chunk(TRIMESH, &trimesh)].concat();
        chunk(MAIN, &chunk(EDITOR, &chunk(OBJECT, &object)))
    }

    #[test]
    fn reads_a_triangle() {
        let mesh = parse_3ds(&triangle_file(2), Path::new("t.3ds")).unwrap();
        assert_eq!(mesh.positions.len(), 3);
        assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn index_out_of_range_names_the_face_byte() {
        let e = parse_3ds(&triangle_file(3), Path::new("t.3ds")).unwrap_err();
        assert!(e.message.contains("out of range"), "{e}");
        assert!(matches!(e.place, Place::Byte(_)));
    }

    #[test]
    fn chunk_past_parent_is_an_error() {
        let mut file = triangle_file(2);
        // Grow the EDITOR chunk's length beyond MAIN's end.
        let len = u32::from_le_bytes([file[8], file[9], file[10], file[11]]) + 1;
        file[8..12].copy_from_slice(&len.to_le_bytes());
        let e = parse_3ds(&file, Path::new("t.3ds")).unwrap_err();
        assert_eq!(e.place, Place::Byte(6));
        assert!(e.message.contains("runs past"), "{e}");
    }
}
