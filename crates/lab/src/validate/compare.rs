//! One ray, two answers: raylab's and Embree's closest hit (and any-hit)
//! compared and the difference classified.
//!
//! The two sides share no arithmetic, so exact equality is not expected,
//! only agreement within rounding; and hit/miss may differ where rounding
//! decides it: a ray through (or within rounding of) a triangle edge or
//! vertex, or one that grazes a surface. [`classify`] says which of these
//! explains a disagreement, and names the side that leaked (missed the
//! surface the other side found).

use super::Tolerances;
use raylab::accel::embree::EmbreeHit;
use raylab::math::{Ray, Vec3};
use raylab::shape::{PrimHit, Primitive, Shape, Triangle};

/// How many t tolerances (as a distance) from an edge a hit point counts
/// as "at the edge". Ten: where the t test passes the two sides' hit
/// points differ by at most one tolerance, and an edge decision is made
/// from the same rounded quantities as t, a few roundings each.
pub const EDGE_BAND: f32 = 10.0;

/// The t tolerance of a grazing hit is the relative one scaled by this
/// over |cos θ|: t's rounding error grows like 1/cos θ, and at
/// cos θ = 0.05 an amplification of 20 still keeps a handful of ε (on
/// both sides) under 10⁻⁵. Checked on 10⁵ random rays into the camel,
/// spheres and ellipsoids (crates/lab/tests/embree.rs); a scale of sin 1° instead
/// fails on an ellipsoid hit at cos θ = 5.6·10⁻³.
pub const GRAZING_T_COS: f32 = 0.05;

/// A closest hit as either side reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Answer {
    pub prim: u32,
    pub hit: PrimHit,
}

/// What both sides answered for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Answers {
    /// raylab's closest hit (through the accelerator under test).
    pub ours: Option<Answer>,
    /// Embree's closest hit, with Embree's own normal.
    pub theirs: Option<EmbreeHit>,
    /// Any-hit over the whole ray (t_max = ∞), raylab and Embree.
    pub any: (bool, bool),
    /// Any-hit over the segment up to half the nearer closest hit (must be
    /// false on both sides: nothing lies before the first hit).
    pub before_first: (bool, bool),
}

/// Where the first hit that one side missed lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum HitPlace {
    /// Within [`EDGE_BAND`] tolerances of one triangle edge.
    Edge,
    /// Within the band of two edges: at a vertex.
    Vertex,
    /// Within the grazing angle of the surface (quadric silhouettes too).
    Grazing,
    /// Within the rounding of the ray's origin (16 ulps of its
    /// coordinates): the ray starts on a surface. raylab traces the open
    /// interval (0, t_max) and skips a surface through its origin, Embree
    /// may report it at t ≈ 0; neither is wrong, and a generator that
    /// draws origins at random (inside a mesh, within the bounds) cannot
    /// avoid landing on some other part of the surface once in a few
    /// hundred thousand rays (armadillo, seed 90217: t = 6.3·10⁻⁹).
    Origin,
    /// None of these: a real disagreement.
    Elsewhere,
}

impl HitPlace {
    pub const ALL: [HitPlace; 5] = [
        HitPlace::Edge,
        HitPlace::Vertex,
        HitPlace::Grazing,
        HitPlace::Origin,
        HitPlace::Elsewhere,
    ];

    pub fn name(self) -> &'static str {
        match self {
            HitPlace::Edge => "edge",
            HitPlace::Vertex => "vertex",
            HitPlace::Grazing => "grazing",
            HitPlace::Origin => "origin",
            HitPlace::Elsewhere => "elsewhere",
        }
    }

    /// Its position in [`HitPlace::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

/// The side that missed the nearer surface the other side found (the
/// other side was watertight there).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leak {
    Raylab,
    Embree,
}

/// What kind of disagreement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DisagreementKind {
    /// One side hit, the other missed.
    HitMiss,
    /// Both hit, different primitives at different t.
    Prim,
}

/// The verdict on one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    BothMiss,
    /// The same primitive.
    Agree,
    /// Different primitives at the same t (within tolerance): a shared
    /// edge or vertex, or coincident (duplicated) faces.
    Tie {
        coincident: bool,
    },
    Disagree {
        kind: DisagreementKind,
        place: HitPlace,
        leak: Leak,
    },
}

/// The verdict and the measurements for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Verdict {
    pub outcome: Outcome,
    /// |cos θ| between the ray and the normal at the first hit (1 if none).
    pub cos: f32,
    /// |Δt| / t for same-primitive hits.
    pub rel_dt: Option<f32>,
    /// Whether the relative tolerance is above the rounding floor of the
    /// coordinates (see [`t_tolerance`]): for a hit a hair from the origin
    /// (or a mesh far from the coordinate origin), |Δt|/t measures the
    /// rounding of the coordinates, not either algorithm.
    pub above_floor: bool,
    /// |Δt| over its tolerance (≤ 1 passes) for same-primitive hits.
    pub t_ratio: Option<f32>,
    /// Distance between the points the two sides' barycentrics name, over
    /// the t tolerance as a distance (≤ 1 passes); triangles only.
    pub uv_ratio: Option<f32>,
    /// Angle (rad) between raylab's normal at Embree's hit point and
    /// Embree's normal, for same-primitive, non-grazing hits.
    pub normal_angle: Option<f32>,
    /// The bound on `normal_angle`: [`Tolerances::normal_angle`], or for a
    /// thin triangle its conditioning bound (see [`normal_tolerance`]).
    pub normal_tolerance: f32,
    /// Any-hit disagrees with Embree's (over the whole ray or before the
    /// first hit) where the closest hits do not explain it.
    pub any_hit_unexplained: bool,
    /// Any-hit disagrees, explained by a borderline closest-hit verdict.
    pub any_hit_explained: bool,
}

impl Verdict {
    /// Whether this ray breaks the tolerances: an unexplained
    /// disagreement, or a same-primitive hit outside the t, (u, v) or
    /// normal bounds.
    pub fn breaks(&self) -> bool {
        matches!(
            self.outcome,
            Outcome::Disagree {
                place: HitPlace::Elsewhere,
                ..
            }
        ) || self.any_hit_unexplained
            || self.t_ratio.is_some_and(|r| r > 1.0)
            || self.uv_ratio.is_some_and(|r| r > 1.0)
            || self.normal_angle.is_some_and(|a| a > self.normal_tolerance)
    }
}

/// Angle between two unit vectors in radians, accurate for small angles
/// (atan2 of sine and cosine rather than acos of the dot product).
pub fn angle(a: Vec3, b: Vec3) -> f32 {
    a.cross(b).length().atan2(a.dot(b))
}

/// |cos θ| between the ray and the outward normal at a hit.
pub fn incidence(prims: &[Primitive], ray: &Ray, p: u32, h: &PrimHit) -> f32 {
    prims[p as usize]
        .outward_normal(ray, h)
        .dot(ray.dir.normalize())
        .abs()
}

/// The largest difference in t accepted between two hits of the same
/// primitive: `t_rel` relative, but never below 16 ulps of the coordinates
/// involved (origin and hit point), and both scaled up by
/// [`GRAZING_T_COS`] / cos θ for hits within the grazing angle. A ray that starts almost on a
/// surface has a tiny t computed from coordinates of order 1 to 10, each
/// rounded to ~10⁻⁷ of its size: that relative error says nothing about
/// either algorithm. Grazing hits: t's rounding error grows like 1/cos θ
/// (a small tilt of the computed plane moves a grazing hit far along the
/// ray; checked in exact arithmetic for a camel ray at cos θ = 5.6·10⁻⁴,
/// where raylab's t is off by 3·10⁻⁶ relative and Embree's by 4·10⁻⁵).
pub fn t_tolerance(tol: &Tolerances, ray: &Ray, prim: &Primitive, h: &PrimHit, cos: f32) -> f32 {
    let grazing = if cos < tol.grazing_cos() {
        (GRAZING_T_COS / cos).max(1.0)
    } else {
        1.0
    };
    (tol.t_rel * h.t).max(floor_tolerance(ray, prim, h)) * grazing
}

/// 16 ulps of the coordinates a hit's t is computed from (origin, hit
/// point, and the primitive's own coordinates: a plane through vertices of
/// size 100 is only known to ~100·ε, wherever the ray meets it — on
/// test1.3ds an inside ray 0.15 from a large face differed by 1.15 floors
/// of the ray's coordinates alone), in units of t.
fn floor_tolerance(ray: &Ray, prim: &Primitive, h: &PrimHit) -> f32 {
    let size = prim
        .bounds()
        .map_or(0.0, |b| b.min.abs().max(b.max.abs()).max_element());
    let scale = ray.origin.length() + ray.at(h.t).length() + size;
    16.0 * f32::EPSILON * scale / ray.dir.length()
}

/// The bound on the angle between the two sides' normals of a primitive:
/// [`Tolerances::normal_angle`], but for a triangle at least what its
/// conditioning allows. A vertex moved by δ tilts the plane by about δ/h,
/// h the triangle's height over the opposite edge; each side computes its
/// edge vectors (Embree from its own leaf layout) from coordinates
/// rounded to ε·max|p|, so with 16 such roundings over the smallest
/// height h_min = 2·area/ℓ_max the normals may differ by
/// 16·ε·max|p|·ℓ_max/(2·area). For the camel's small, thin triangles
/// this reaches 3·10⁻⁴ (and the two sides did differ by 3.3·10⁻⁴); for
/// well-shaped ones it stays under 10⁻⁵.
pub fn normal_tolerance(tol: &Tolerances, prim: &Primitive) -> f32 {
    match &prim.shape {
        Shape::Triangle(t) => {
            let size =
                t.p.iter()
                    .map(|p| p.abs().max_element())
                    .fold(0.0, f32::max);
            let longest = (0..3)
                .map(|k| t.p[k].distance(t.p[(k + 1) % 3]))
                .fold(0.0, f32::max);
            let bound = 16.0 * f32::EPSILON * size * longest / (2.0 * t.area());
            tol.normal_angle.max(bound)
        }
        _ => tol.normal_angle,
    }
}

/// The point (1−u−v)·p0 + u·p1 + v·p2 of a triangle.
fn barycentric_point(t: &Triangle, h: &PrimHit) -> Vec3 {
    (1.0 - h.u - h.v) * t.p[0] + h.u * t.p[1] + h.v * t.p[2]
}

/// World distances from a triangle hit to its three edges (opposite
/// vertex 0, 1, 2): each barycentric times the height over that edge.
fn edge_distances(t: &Triangle, h: &PrimHit) -> [f32; 3] {
    let twice_area = 2.0 * t.area();
    let height = |a: Vec3, b: Vec3| twice_area / (b - a).length();
    let w = 1.0 - h.u - h.v;
    [
        (w * height(t.p[1], t.p[2])).abs(),
        (h.u * height(t.p[2], t.p[0])).abs(),
        (h.v * height(t.p[0], t.p[1])).abs(),
    ]
}

/// Where a hit lies for the purpose of explaining a disagreement: at the
/// ray's origin (within the rounding of its coordinates), at an edge or
/// vertex (triangles, within [`EDGE_BAND`] t tolerances), grazing, or
/// elsewhere.
pub fn place(tol: &Tolerances, prims: &[Primitive], ray: &Ray, p: u32, h: &PrimHit) -> HitPlace {
    let prim = &prims[p as usize];
    if h.t <= floor_tolerance(ray, prim, h) {
        return HitPlace::Origin;
    }
    let cos = incidence(prims, ray, p, h);
    if let Shape::Triangle(t) = &prims[p as usize].shape {
        let band = EDGE_BAND * t_tolerance(tol, ray, prim, h, cos) * ray.dir.length();
        match edge_distances(t, h).iter().filter(|&&d| d < band).count() {
            0 => {}
            1 => return HitPlace::Edge,
            _ => return HitPlace::Vertex,
        }
    }
    if cos < tol.grazing_cos() {
        HitPlace::Grazing
    } else {
        HitPlace::Elsewhere
    }
}

fn embree_answer(e: &EmbreeHit) -> Answer {
    Answer {
        prim: e.prim,
        hit: e.hit,
    }
}

/// Classify one ray's answers.
pub fn classify(tol: &Tolerances, prims: &[Primitive], ray: &Ray, a: &Answers) -> Verdict {
    let theirs = a.theirs.as_ref().map(embree_answer);
    let mut v = Verdict {
        outcome: Outcome::BothMiss,
        cos: 1.0,
        rel_dt: None,
        above_floor: false,
        t_ratio: None,
        uv_ratio: None,
        normal_angle: None,
        normal_tolerance: tol.normal_angle,
        any_hit_unexplained: false,
        any_hit_explained: false,
    };
    match (a.ours, theirs) {
        (None, None) => {}
        (Some(o), Some(e)) if o.prim == e.prim => {
            let cos = incidence(prims, ray, o.prim, &o.hit);
            let prim = &prims[o.prim as usize];
            let t_tol = t_tolerance(tol, ray, prim, &o.hit, cos);
            let dt = (e.hit.t - o.hit.t).abs();
            v.outcome = Outcome::Agree;
            v.cos = cos;
            v.above_floor = tol.t_rel * o.hit.t >= floor_tolerance(ray, prim, &o.hit);
            v.rel_dt = Some(dt / o.hit.t);
            v.t_ratio = Some(dt / t_tol);
            // Embree's u, v must be raylab's barycentrics (of vertices 1
            // and 2): the points they name agree as the hit points do. A
            // swapped or complemented convention is off by a good part of
            // the triangle. Quadrics report no surface coordinates.
            // Not for grazing hits (|cos θ| below GRAZING_T_COS, ~2.9°,
            // where t's tolerance starts to grow), where the ray crosses the
            // plane is itself uncertain: on spider.obj (coordinates ~200,
            // thin triangles) hits at 0.93° and at 1.7° (seed 112) missed
            // by 1.1 and 1.25 tolerances.
            let triangle = match &prims[o.prim as usize].shape {
                Shape::Triangle(t) if cos >= tol.grazing_cos().max(GRAZING_T_COS) => Some(t),
                _ => None,
            };
            if let Some(t) = triangle {
                // An error δ across the plane moves a hit at incidence θ by
                // δ/cos θ within it, at every angle: so the (u, v) bound
                // keeps the grazing scale down to cos θ = GRAZING_T_COS
                // (as the t bound did before the 1° criterion).
                let in_plane = (GRAZING_T_COS / cos).max(1.0);
                // The points are (1−u−v)·p0 + u·p1 + v·p2, each rounded to
                // ~ε·max|pᵢ|: near the origin (t → 0, coordinates of the ray
                // far smaller than the triangle's) that rounding is the
                // floor, not the ray's (cube_binary.ply, an inside ray
                // 4·10⁻⁴ from a unit face: 1.01 of the ray's floor).
                let size =
                    t.p.iter()
                        .map(|p| p.abs().max_element())
                        .fold(0.0, f32::max);
                let vertex_floor = 16.0 * f32::EPSILON * size / ray.dir.length();
                let uv_tol = (tol.t_rel * o.hit.t)
                    .max(floor_tolerance(ray, prim, &o.hit))
                    .max(vertex_floor)
                    * in_plane;
                let gap = barycentric_point(t, &o.hit).distance(barycentric_point(t, &e.hit));
                v.uv_ratio = Some(gap / (uv_tol.max(t_tol) * ray.dir.length()));
            }
            // raylab's normal at Embree's hit point against Embree's own:
            // evaluated at raylab's hit instead, the comparison would
            // mostly measure Δt times the curvature. Not for grazing hits,
            // where Embree's own normal comes from an uncertain point.
            if cos >= tol.grazing_cos() {
                let theirs = a.theirs.expect("matched Some");
                let prim = &prims[o.prim as usize];
                let n = prim.outward_normal(ray, &theirs.hit);
                v.normal_angle = Some(angle(n, theirs.normal));
                v.normal_tolerance = normal_tolerance(tol, prim);
            }
        }
        (Some(o), Some(e))
            if (e.hit.t - o.hit.t).abs()
                <= t_tolerance(
                    tol,
                    ray,
                    &prims[o.prim as usize],
                    &o.hit,
                    incidence(prims, ray, o.prim, &o.hit),
                ) =>
        {
            v.cos = incidence(prims, ray, o.prim, &o.hit);
            // At a shared edge or vertex either neighbour is right; away
            // from edges, two faces at the same t are coincident.
            let at_edge = matches!(
                place(tol, prims, ray, o.prim, &o.hit),
                HitPlace::Edge | HitPlace::Vertex
            ) || matches!(
                place(tol, prims, ray, e.prim, &e.hit),
                HitPlace::Edge | HitPlace::Vertex
            );
            v.outcome = Outcome::Tie {
                coincident: !at_edge,
            };
        }
        (ours, theirs) => {
            // The first hit decides: the other side missed it.
            let (first, leak) = match (ours, theirs) {
                (Some(o), Some(e)) if o.hit.t < e.hit.t => (o, Leak::Embree),
                (Some(_), Some(e)) => (e, Leak::Raylab),
                (Some(o), None) => (o, Leak::Embree),
                (None, Some(e)) => (e, Leak::Raylab),
                (None, None) => unreachable!("handled above"),
            };
            let kind = if ours.is_some() && theirs.is_some() {
                DisagreementKind::Prim
            } else {
                DisagreementKind::HitMiss
            };
            v.cos = incidence(prims, ray, first.prim, &first.hit);
            v.outcome = Outcome::Disagree {
                kind,
                place: place(tol, prims, ray, first.prim, &first.hit),
                leak,
            };
        }
    }
    let any_hit_differs = a.any.0 != a.any.1 || a.before_first.0 != a.before_first.1;
    // Each side's any-hit must also match its own closest hit: a side that
    // reports a hit but says nothing occludes the ray is inconsistent.
    let inconsistent = a.any.0 != a.ours.is_some() || a.any.1 != a.theirs.is_some();
    if any_hit_differs || inconsistent {
        let borderline = matches!(
            v.outcome,
            Outcome::Disagree { place, .. } if place != HitPlace::Elsewhere
        );
        if borderline && !inconsistent {
            v.any_hit_explained = true;
        } else {
            v.any_hit_unexplained = true;
        }
    }
    v
}
