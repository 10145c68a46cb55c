//! The curves seen from a path vertex, picked on values before the one
//! drawn is built on dual numbers: the candidates among silhouettes, mesh
//! edges and meeting curves, and the curve of a pick on any [`Real`]
//! ([`super::vertex`], [`super::area`]).

use super::curves::{edge_curve, edge_matters, smooth_silhouette, Curve, Edge};
use super::meeting::meeting;
use crate::math::{Real, Vec3, V3};
use crate::scene::Scene;
use crate::shape::{Shape, ShapeR};

/// A curve seen from a shading point, chosen on values before it is built
/// on dual numbers: a smooth primitive's silhouette, a mesh edge (an
/// index into [`super::curves::mesh_edges`]) or the curve where two
/// primitives meet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pick {
    Smooth(u32),
    Edge(usize),
    /// Where two primitives pass through each other ([`meeting`]).
    Meeting(u32, u32),
}

/// The curves along which what `o` sees changes, other than those of
/// primitive `own` (the surface `o` lies on): silhouettes of spheres and
/// ellipsoids, the mesh edges that matter ([`edge_matters`], creases
/// with `creases`) and the curves where the pairs `meetings` pass through
/// each other ([`super::meeting::meeting_pairs`]), of the objects
/// `include` accepts.
pub fn candidates(
    scene: &Scene,
    (edges, meetings): (&[Edge], &[(u32, u32)]),
    o: Vec3,
    own: u32,
    creases: bool,
    include: impl Fn(u32) -> bool,
) -> Vec<Pick> {
    let mut picks = Vec::new();
    for (prim, p) in scene.prims.iter().enumerate() {
        let prim = prim as u32;
        let smooth = matches!(p.shape, Shape::Sphere(_) | Shape::Ellipsoid(_));
        if smooth && prim != own && include(p.object) {
            let shape = ShapeR::<f32>::of(p);
            if smooth_silhouette(&shape, V3::from_vec3(o)).is_some() {
                picks.push(Pick::Smooth(prim));
            }
        }
    }
    for (i, e) in edges.iter().enumerate() {
        let object = scene.prims[e.faces[0] as usize].object;
        if !e.faces.contains(&own) && include(object) && edge_matters(scene, e, o, creases) {
            picks.push(Pick::Edge(i));
        }
    }
    // A meeting curve lies on both surfaces: from a point on either it is
    // behind that surface or in its tangent plane.
    let object = |prim: u32| scene.prims[prim as usize].object;
    picks.extend(
        meetings
            .iter()
            .filter(|&&(a, b)| a != own && b != own && (include(object(a)) || include(object(b))))
            .map(|&(a, b)| Pick::Meeting(a, b)),
    );
    picks
}

/// The curve `pick` seen from `o`, built from the primitives' geometry
/// `geometry(prim)` (on any [`Real`]); `None` when `o` is inside a smooth
/// primitive.
pub fn build<R: Real>(
    pick: Pick,
    edges: &[Edge],
    o: V3<R>,
    geometry: impl Fn(u32) -> ShapeR<R>,
) -> Option<Curve<R>> {
    match pick {
        Pick::Smooth(prim) => smooth_silhouette(&geometry(prim), o),
        Pick::Meeting(a, b) => meeting(&geometry(a), &geometry(b)),
        Pick::Edge(i) => Some(edge_curve(&edges[i], |prim, corner| match geometry(prim) {
            ShapeR::Triangle { p } => p[corner],
            _ => unreachable!("mesh edges join triangles"),
        })),
    }
}
