//! Triangle meshes as data: positions, optional vertex normals and
//! triangles as index triples, in the mesh's own coordinates. The readers
//! ([`crate::io::mesh`]) and generators ([`crate::io::procedural`]) make
//! them; a scene places them with an object transform and splits them into
//! [`Triangle`](super::Triangle) primitives.

use glam::Vec3;

/// A triangle mesh as read from a file or generated. Polygons are split into triangle
/// fans. `normals` is empty or holds one unit normal per position.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions, finite, in the file's coordinates.
    pub positions: Vec<Vec3>,
    /// Unit vertex normals, one per position, or empty when the file has
    /// none (or one that is zero or not finite).
    pub normals: Vec<Vec3>,
    /// Triangles as indices into `positions`, all in range.
    pub triangles: Vec<[u32; 3]>,
}
