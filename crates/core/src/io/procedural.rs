//! Procedural meshes for scaling studies: deterministic, any size, no files.
//!
//! - `icosphere`: an icosahedron subdivided `level` times, vertices pushed
//!   to the unit sphere: 20·4^level triangles (level 9 ≈ 5.2 M).
//! - `torus_knot`: a (p, q) torus knot swept by a circular tube:
//!   2·segments·sides triangles.
//! - `terrain`: an n×n height field of value noise over [−1, 1]²:
//!   2·n² triangles.
//!
//! All three are closed or regular surfaces with no degenerate triangles,
//! and the same parameters always give the same mesh, bit for bit.

use super::MeshData;
use crate::math::SplitMix64;
use glam::Vec3;
use serde::Deserialize;
use std::collections::HashMap;

/// The procedural meshes a scene file can ask for
/// (`procedural = { kind = "icosphere", level = 5 }`).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Procedural {
    Icosphere {
        level: u32,
    },
    TorusKnot {
        p: u32,
        q: u32,
        segments: u32,
        sides: u32,
    },
    Terrain {
        n: u32,
        seed: u64,
    },
}

/// The most triangles a procedural mesh may have (about 2 GB of
/// primitives): larger requests are refused rather than exhausting memory.
pub const MAX_TRIANGLES: u64 = 40_000_000;

/// Why a procedural mesh's parameters are unusable.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ProceduralError {
    /// More triangles than [`MAX_TRIANGLES`].
    #[error("{count} triangles requested; the limit is {MAX_TRIANGLES}")]
    TooManyTriangles {
        /// The triangles the parameters ask for.
        count: u64,
    },
    /// A torus knot with a zero winding or too few segments or sides.
    #[error("torus_knot needs p, q ≥ 1 and segments, sides ≥ 3")]
    TorusKnot,
    /// A terrain of no cells.
    #[error("terrain needs n ≥ 1")]
    Terrain,
    /// More triangles than the memory available can hold once built.
    #[error(transparent)]
    Memory(#[from] crate::film::memory::MemoryError),
}

impl Procedural {
    /// Number of triangles this mesh will have.
    pub fn triangle_count(&self) -> u64 {
        match *self {
            Procedural::Icosphere { level } => 20u64.saturating_mul(4u64.saturating_pow(level)),
            Procedural::TorusKnot {
                segments, sides, ..
            } => 2 * segments as u64 * sides as u64,
            Procedural::Terrain { n, .. } => 2 * n as u64 * n as u64,
        }
    }

    /// Generate the mesh, or explain why the parameters are unusable.
    pub fn generate(&self) -> Result<MeshData, ProceduralError> {
        let count = self.triangle_count();
        if count > MAX_TRIANGLES {
            return Err(ProceduralError::TooManyTriangles { count });
        }
        // Checked before generating: what the mesh will hold once a tree
        // is built over it.
        crate::film::memory::check(
            || format!("a mesh of {count} triangles (its data and tree)"),
            u128::from(count) * crate::film::memory::TRIANGLE_BYTES,
        )?;
        match *self {
            Procedural::Icosphere { level } => Ok(icosphere(level)),
            Procedural::TorusKnot {
                p,
                q,
                segments,
                sides,
            } => {
                if p == 0 || q == 0 || segments < 3 || sides < 3 {
                    return Err(ProceduralError::TorusKnot);
                }
                Ok(torus_knot(p, q, segments, sides))
            }
            Procedural::Terrain { n, seed } => {
                if n == 0 {
                    return Err(ProceduralError::Terrain);
                }
                Ok(terrain(n, seed))
            }
        }
    }
}

/// Unit icosphere with `level` subdivisions.
pub fn icosphere(level: u32) -> MeshData {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        // Each edge's midpoint is made once and shared by both triangles.
        let mut midpoints: HashMap<(u32, u32), u32> =
            HashMap::with_capacity(triangles.len() * 3 / 2);
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                let m = (positions[a as usize] + positions[b as usize]).normalize();
                positions.push(m);
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    let normals = positions.clone();
    MeshData {
        positions,
        normals,
        triangles,
    }
}

/// A (p, q) torus knot (radius 1 ± 0.4) swept by a tube of radius 0.15.
pub fn torus_knot(p: u32, q: u32, segments: u32, sides: u32) -> MeshData {
    let curve = |s: f32| {
        let (pf, qf) = (p as f32, q as f32);
        let r = 1.0 + 0.4 * (qf * s).cos();
        Vec3::new(r * (pf * s).cos(), r * (pf * s).sin(), 0.4 * (qf * s).sin())
    };
    let tube = 0.15;
    let tau = std::f32::consts::TAU;
    let mut positions = Vec::with_capacity((segments * sides) as usize);
    let mut normals = Vec::with_capacity(positions.capacity());
    for i in 0..segments {
        let s = tau * i as f32 / segments as f32;
        let c = curve(s);
        let tangent = (curve(s + 1e-3) - curve(s - 1e-3)).normalize();
        // A frame that is smooth along the closed curve: the curve point's
        // direction from the z axis, made orthogonal to the tangent.
        let radial = Vec3::new(c.x, c.y, 0.0);
        let n1 = (radial - radial.dot(tangent) * tangent).normalize();
        let n2 = tangent.cross(n1);
        for j in 0..sides {
            let a = tau * j as f32 / sides as f32;
            let n = a.cos() * n1 + a.sin() * n2;
            positions.push(c + tube * n);
            normals.push(n);
        }
    }
    let mut triangles = Vec::with_capacity(2 * (segments * sides) as usize);
    let idx = |i: u32, j: u32| (i % segments) * sides + (j % sides);
    for i in 0..segments {
        for j in 0..sides {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    MeshData {
        positions,
        normals,
        triangles,
    }
}

/// Value noise: random values on an integer lattice, smoothly interpolated
/// (smoothstep), summed over four octaves.
fn value_noise(x: f32, y: f32, seed: u64) -> f32 {
    let lattice = |i: i64, j: i64, octave: u64| {
        let h = SplitMix64::mix(
            seed ^ SplitMix64::mix((i as u64) ^ SplitMix64::mix((j as u64) ^ (octave << 56))),
        );
        (h >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    let mut sum = 0.0;
    let (mut freq, mut amp) = (2.0f32, 0.5f32);
    for octave in 0..4 {
        let (fx, fy) = (x * freq, y * freq);
        let (i, j) = (fx.floor() as i64, fy.floor() as i64);
        let (tx, ty) = (fx - fx.floor(), fy - fy.floor());
        let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
        let a = lattice(i, j, octave) + sx * (lattice(i + 1, j, octave) - lattice(i, j, octave));
        let b = lattice(i, j + 1, octave)
            + sx * (lattice(i + 1, j + 1, octave) - lattice(i, j + 1, octave));
        sum += amp * (a + sy * (b - a));
        freq *= 2.0;
        amp *= 0.5;
    }
    sum
}

/// An n×n height field over [−1, 1]² with heights in about [−0.3, 0.3].
pub fn terrain(n: u32, seed: u64) -> MeshData {
    let m = n + 1;
    let mut positions = Vec::with_capacity((m * m) as usize);
    for j in 0..m {
        for i in 0..m {
            let x = -1.0 + 2.0 * i as f32 / n as f32;
            let z = -1.0 + 2.0 * j as f32 / n as f32;
            positions.push(Vec3::new(x, 0.3 * value_noise(x, z, seed), z));
        }
    }
    let mut triangles = Vec::with_capacity(2 * (n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let a = j * m + i;
            let (b, c, d) = (a + 1, a + m + 1, a + m);
            // Counter-clockwise seen from above (+y).
            triangles.push([a, d, c]);
            triangles.push([a, c, b]);
        }
    }
    MeshData {
        positions,
        normals: Vec::new(),
        triangles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_match_formulas_and_meshes_are_valid() {
        for p in [
            Procedural::Icosphere { level: 3 },
            Procedural::TorusKnot {
                p: 2,
                q: 3,
                segments: 64,
                sides: 8,
            },
            Procedural::Terrain { n: 17, seed: 5 },
        ] {
            let m = p.generate().unwrap();
            assert_eq!(m.triangles.len() as u64, p.triangle_count(), "{p:?}");
            let nv = m.positions.len() as u32;
            assert!(m.triangles.iter().flatten().all(|&i| i < nv));
            assert!(m.positions.iter().all(|v| v.is_finite()));
            for t in &m.triangles {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                assert!(
                    (b - a).cross(c - a).length() > 0.0,
                    "degenerate triangle in {p:?}"
                );
            }
        }
        // Icosphere: Euler characteristic 2 (closed genus-0 surface).
        let m = icosphere(2);
        let (v, f) = (m.positions.len() as i64, m.triangles.len() as i64);
        assert_eq!(v - 3 * f / 2 + f, 2);
        assert_eq!(terrain(8, 1), terrain(8, 1));
        assert!(Procedural::Icosphere { level: 20 }.generate().is_err());
    }
}
