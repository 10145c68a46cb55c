//! Edges seen in curved mirrors and through glass: what the Whitted
//! integrator's reflected and refracted rays find when the surface that
//! sends them on is a sphere or an ellipsoid.
//!
//! A flat mirror shows the scene from one point, the eye's mirror image
//! ([`super::mirror`]), so each 3-D curve has one image. A curved mirror
//! does not: film point x sees along its own reflected ray, from o(x) on
//! the mirror in direction d(x), and the film curves along which the
//! reflection changes are level sets, not projections. A glass sphere or
//! ellipsoid is the same with other (o(x), d(x)): the camera ray
//! refracted in at the near side and out where it meets the far side, or
//! reflected there once or twice first (the object is taken to sit in
//! air, and where the ray would leave by total internal reflection that
//! way has no ray). Below, "mirror" is either.
//!
//! The ray that leaves a mirror may meet another, and a mirror may be
//! seen in the floor: every sequence of specular bounces the renderer
//! traces that includes a curved one is a chain (module `chain`) with a
//! curve family of its own, its (o(x), d(x)) the ray leaving its last
//! bounce. Planes before its first curved bounce are folded into the eye
//! (the grid lies on that mirror's disc as the eye's mirror image sees
//! it); the bounces after it are followed ray by ray.
//! For each thing that makes an edge there, φ(x, θ) is a function that
//! changes sign exactly across it:
//!
//! - a sphere's or an ellipsoid's silhouette: the distance from the line
//!   o + λd to the centre less the radius (in the ellipsoid's unit-sphere
//!   space), where the closest approach lies ahead (λ > 0);
//! - a plane's horizon: d·n, signed by the side of the plane o lies on;
//! - a point light's shadow edge cast by a sphere or an ellipsoid: the
//!   same distance for the shadow ray from the point the ray leaving the
//!   mirror meets (from its origin ε off the surface, as the renderer's
//!   shadow rays start), where the closest approach lies between it and
//!   the light.
//!
//! **Finding the curve.** The film squeezes a mirror's rim: there the
//! reflected rays, and so φ, change ever faster with the film position,
//! and what lies behind the mirror crowds into a thin ring. On the mirror
//! itself they change smoothly up to the rim. So the curve is found on a
//! grid over the visible part of the mirror, as a disc (X, Y)
//! (`grid::Cap`): a square grid mapped onto the whole disc, its sides
//! onto the rim, with cells about [`STEP_PX`] pixels wide on the film at
//! its centre and at least `MIN_CELLS` across (the camera ray and the
//! rays along the chain per grid point, shared by all the chain's
//! curves; a coarse grid first says where the chain is followed, and the
//! grid covers only that window, none at all where it is followed
//! nowhere). Where φ changes sign along a cell side, bisection places
//! the crossing (marching squares; a saddle is resolved by φ at the
//! cell's centre), and each cell crossed gives a chord [a, b] on the disc
//! whose ends lie on the curve, shared with the neighbouring cells'
//! chords. A later curved object in the chain has a rim of its own
//! inside the grid, where what it shows crowds as the first's does on
//! the film: a cell cut off there (some corners follow the chain, and one
//! that does not is cut off at that object) is halved `REFINE_LEVELS`
//! times where it still is, and its sub-cells whose corners all follow
//! the chain take its place.
//!
//! **Sampling it.** A sample picks a chord in proportion to its length ℓ
//! (of total L) and a point a + u·(b − a) on it, u uniform, and moves it
//! along the chord's unit normal m onto the curve: p(u) = a + u·(b − a) +
//! s(u)·m with φ(p(u)) = 0 (Newton's method; derivatives over (X, Y) by
//! forward mode on two-wide duals). This maps each chord onto the arc
//! between its ends, and the film point is x(u) = film(p(u)), so the
//! curve's line integral on the film is Σ ∫₀¹ g(x(u)) |dx/du| du with
//! dx/du = J·((b − a) + s′·m), J = ∂x/∂(X, Y) and s′ = −∇φ·(b − a) / ∇φ·m
//! (the implicit function); g·|dx/du|·L/ℓ is an unbiased estimate of it.
//! The integrand is the one of every curve, g = (f⁻ − f⁺)(∂x/∂θ·n), with
//! n = ∇ₓφ / |∇ₓφ| (∇ₓφ = J⁻ᵀ∇φ) and the curve's normal speed from the
//! implicit function, ∂x/∂θ·n = −(∂φ/∂θ) / |∇ₓφ|, where ∂φ/∂θ comes from
//! the K-wide duals of the [`DualScene`] at fixed film position (the
//! mirror, the camera, the objects, the lights and the glass's index of
//! refraction all move it). f± are the integrator's, at x ± ε·n.
//!
//! **What it misses.** Pieces of a curve the grid does not see: a closed
//! loop inside one cell, arcs in cells whose corners do not all see the
//! mirror (where something in front hides part of it, or a plane's
//! horizon cuts the chain off), the last 10⁻³ pixel of a curve at the
//! rim, where one side of the jump would see past the mirror, and at a
//! later curved object's rim the last 2^−`REFINE_LEVELS` of a cell.
//! Chains seen only on a part of the disc that the coarse grid
//! (`COARSE_CELLS` across) misses. Not covered at all: triangle meshes'
//! edges and shadows seen in a curved mirror or through glass, chains
//! with a triangle mirror in them, more than two reflections inside
//! glass, glass that is not a sphere or an ellipsoid, and a mirror that
//! touches what it reflects (contact, as for every curve).

mod chain;
mod grid;

use super::sums::{jump, landed, offset, CurveResult, SparseSums};
use super::{light_moves, BoundaryStats};
use crate::camera::Frame;
use crate::diff::params::is_camera;
use crate::diff::view::DualScene;
use crate::integrator::IntegratorKind;
use crate::math::{Dual, RayR, Real, SplitMix64, V3};
use crate::scene::param::ParamId;
use crate::scene::{Scene, View};
use crate::shape::{HitR, Shape, ShapeR};
use chain::{chains, leaving, trace, Chain, Trace};
use glam::Vec2;
use grid::{Cap, Grid};
use rayon::prelude::*;

/// The side of the grid's cells, in pixels.
pub const STEP_PX: f32 = 0.25;

/// The most cells across a grid: 2048, reached by a disc 256 pixels in
/// radius on the film (cells of a quarter pixel), beyond which cells grow.
/// With 4096 a grid's traced points alone could take 6.5 GB.
const MAX_CELLS: usize = 2048;

/// What one curved mirror's grid can hold at most, the boundary term's
/// largest piece of memory beside its planes (`raylab grad` counts it,
/// [`crate::diff::gradient_bytes`]): its traced points, one per corner of
/// `MAX_CELLS`² cells, and a flag per cell; zero where the scene has no
/// curved mirror or glass for Whitted to look through. The grids of the
/// chains are made one at a time.
pub fn grid_bytes(scene: &Scene) -> u128 {
    if chain::chains(scene).is_empty() {
        return 0;
    }
    let corners = (MAX_CELLS as u128 + 1).pow(2);
    corners * std::mem::size_of::<Result<chain::Trace, chain::CutOff>>() as u128
        + (MAX_CELLS as u128).pow(2)
}

/// The fewest cells across a grid, whatever the disc's size on the film.
/// What a mirror or a glass sphere shows is squeezed into its disc at the
/// scale of the scene, not of the image: a small image's few pixels per
/// disc gave cells too coarse for the curves in it (a loop inside one
/// cell, two crossings on one side), and their pixels got no boundary
/// term at all. On S1's scene at 32×32 pixels, where the mirror's and
/// the glass's discs are 5–8 pixels across, moving the mirror, the glass
/// or the camera passed on 98.5–98.9 % of the pixels with cells of a
/// quarter pixel; with at least 128 across, on 99.3–99.7 %.
const MIN_CELLS: usize = 128;

/// How many times a cell cut off at a later curved object's rim is
/// halved (`grid::Grid::refine`): to 1/16 of a cell, about 0.016 pixel
/// at the studies' sizes. On S1's scene at 320×320 pixels (`jitter:8`),
/// moving the mirror's radius, the boundary term in the 10×10 pixels
/// where the mirror's rim seen through the glass shows the floor in the
/// mirror's own shadow reads −0.17 with no refinement, −0.35 with 3
/// levels, −0.40 with 4 and −0.45 with 5 (one seed). Over four seeds,
/// the whole derivative there reads −0.12 with 4 levels and +0.16
/// without, against −0.22 from central differences (the rest is the
/// interior term's heavy tail: rim zones are not sampled through glass),
/// and the image mean 4.63·10⁻³ against 4.82·10⁻³ without and 4.16·10⁻³
/// from central differences (S1's contacts hold most of the rest).
/// Cost, at S1's 32×32 pixels in `crates/core/tests/boundary/`: the boundary term
/// takes about 0.6 s with none, 1.0 s with 4 levels and 1.1 s with 5,
/// and that file's S1 test 85, 150 and 220 s (measured before marching
/// squares kept a mask of the refined cells, which took the whole file
/// from 467 s to 398 s with 4 levels; 336 s with none).
const REFINE_LEVELS: u32 = 4;

/// Cells across the coarse grid that says whether a chain is seen at all.
const COARSE_CELLS: usize = 32;

/// Bisections placing a crossing on a cell side (2⁻¹⁶ of it).
const BISECTIONS: usize = 16;

/// How far the bisection's bracket values must have shrunk, against φ at
/// the side's ends, for a sign change to count as a zero of φ and not a
/// jump (where what the leaving ray meets changes, φ jumps by a sizeable
/// part of its values and the bracket keeps them). Near a mirror's rim φ
/// carries f32 noise of up to 10⁻² of its values at the ends of a side
/// (measured 2·10⁻³–7·10⁻³ on S1's mirror, where the floor's shadows
/// crowd against the rim); a threshold of 10⁻³ took those crossings for
/// jumps, and the reflected shadow edge of S1's red sphere stopped
/// 1.5 pixels (at 320×320) short of where it meets the mirror's rim. A
/// jump let through is refused by Newton's method, which must reach
/// φ = 0 ([`onto_curve`]).
const ZERO_SHRINK: f32 = 0.05;

/// Newton steps moving a chord's point onto the curve, and the step
/// below which it has arrived (pixels).
const NEWTON_STEPS: usize = 16;
const NEWTON_TOLERANCE_PX: f32 = 1e-4;

/// What makes an edge seen in a curved mirror.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    /// The silhouette of primitive `prim` (a sphere or an ellipsoid).
    Silhouette(u32),
    /// The horizon of plane `prim`.
    Horizon(u32),
    /// The shadow edge that `occluder` (a sphere or an ellipsoid) casts
    /// from point light `light`.
    Shadow { light: usize, occluder: u32 },
}

/// One curve seen in one curved mirror: chords with their ends on it and
/// their lengths' running sums, and how many samples it gets.
pub struct CurvedJob {
    disc: Disc,
    target: Target,
    chords: Vec<[Vec2; 2]>,
    ends: Vec<f32>,
    pub samples: u32,
}

/// How far the line o + λd passes outside `shape` (a sphere, or an
/// ellipsoid in its unit-sphere space) and the λ of its closest approach.
fn gap<R: Real>(o: V3<R>, d: V3<R>, shape: &ShapeR<R>) -> Option<(R, R)> {
    let (f, d, r) = match *shape {
        ShapeR::Sphere { centre, radius } => (o - centre, d, radius),
        ShapeR::Ellipsoid { centre, to_unit } => {
            (to_unit.mul_vec(o - centre), to_unit.mul_vec(d), R::one())
        }
        ShapeR::Plane { .. } | ShapeR::Triangle { .. } => return None,
    };
    let dd = d.dot(d);
    Some((f.cross(d).length() / dd.sqrt() - r, -f.dot(d) / dd))
}

/// The geometry φ is a function of, on one number type, with each
/// primitive's index of refraction.
struct Setup<'a, R, G, L, I> {
    frame: &'a Frame<R>,
    size: (u32, u32),
    geometry: G,
    light: L,
    ior: I,
}

impl<R, G, L, I> Setup<'_, R, G, L, I>
where
    R: Real,
    G: Fn(u32) -> ShapeR<R>,
    L: Fn(usize) -> V3<R>,
    I: Fn(u32) -> R,
{
    /// φ of `target` in `disc`'s mirror at film point `(x, y)`, whose
    /// rays are `trace` (see the module docs); `None` where it makes no
    /// edge.
    fn phi(&self, (x, y): (R, R), disc: &Disc, target: Target, trace: &Trace) -> Option<R> {
        let shape = |p: u32| ((self.geometry)(p), (self.ior)(p));
        let hits = |i: usize, _: &RayR<R>| trace.hits[i];
        let out = leaving(self.frame, self.size, (x, y), &disc.chain, shape, hits)?;
        self.phi_along(out, target, trace)
    }

    /// [`Self::phi`] given the ray `(o, d)` that leaves the mirror.
    fn phi_along(&self, (o, d): (V3<R>, V3<R>), target: Target, trace: &Trace) -> Option<R> {
        match target {
            Target::Silhouette(prim) => {
                let (gap, along) = gap(o, d, &(self.geometry)(prim))?;
                (along.value() > 0.0).then_some(gap)
            }
            Target::Horizon(prim) => {
                let ShapeR::Plane { point, normal } = (self.geometry)(prim) else {
                    return None;
                };
                let side = if (o - point).dot(normal).value() < 0.0 {
                    -1.0
                } else {
                    1.0
                };
                Some(d.dot(normal) * R::from_f32(side))
            }
            Target::Shadow { light, occluder } => {
                let next = trace.next?;
                if next.prim == occluder {
                    return None;
                }
                let receiver = (self.geometry)(next.prim);
                let q = HitR::on(&receiver, None, &RayR::new(o, d), next);
                let l = (self.light)(light);
                let start = q.spawn_origin(l - q.point);
                let to = l - start;
                let len = to.length();
                let (gap, along) = gap(start, to / len, &(self.geometry)(occluder))?;
                (along.value() > 0.0 && along.value() < len.value()).then_some(gap)
            }
        }
    }
}

/// The disc ([`Cap`]) of a chain's first curved object on a film of
/// `size` pixels, the chain, and its grid's step there (about
/// [`STEP_PX`] on the film at the disc's centre).
#[derive(Clone, Copy)]
struct Disc {
    chain: Chain,
    size: (u32, u32),
    cap: Cap,
    step: f32,
}

/// What φ is at a disc point: its value, ∇φ over (X, Y), the film
/// position's Jacobian J = ∂x/∂(X, Y) (columns), the film position and
/// the rays traced there.
struct Local {
    value: f32,
    grad: Vec2,
    jacobian: [Vec2; 2],
    film: Vec2,
    trace: Trace,
}

impl Local {
    /// ∇ₓφ on the film: J⁻ᵀ ∇φ.
    fn film_gradient(&self) -> Vec2 {
        let [c0, c1] = self.jacobian;
        let det = c0.x * c1.y - c1.x * c0.y;
        Vec2::new(
            c1.y * self.grad.x - c0.y * self.grad.y,
            -c1.x * self.grad.x + c0.x * self.grad.y,
        ) / det
    }
}

/// φ at disc point `p` of `grid`'s mirror on the scene's values, with its
/// derivatives over the disc.
fn local(
    scene: &Scene,
    grid: &Disc,
    target: Target,
    p: Vec2,
    stats: &mut BoundaryStats,
) -> Option<Local> {
    let frame: Frame<Dual<2>> = scene.camera.frame().lift();
    let size = (scene.camera.width, scene.camera.height);
    let xy = (Dual::variable(p.x, 0), Dual::variable(p.y, 1));
    let (fx, fy) = grid.cap.film(&frame, size, xy)?;
    stats.light_rays += grid.chain.rays();
    let trace = trace(scene, (fx.v, fy.v), &grid.chain)?;
    let setup = Setup {
        frame: &frame,
        size,
        geometry: |p: u32| ShapeR::of(&scene.prims[p as usize]),
        light: |i: usize| V3::from_vec3(scene.lights[i].position),
        ior: |p: u32| Dual::from_f32(View::material(scene, scene.prims[p as usize].object).ior),
    };
    let v = setup.phi((fx, fy), grid, target, &trace)?;
    Some(Local {
        value: v.v,
        grad: Vec2::new(v.d[0], v.d[1]),
        jacobian: [Vec2::new(fx.d[0], fy.d[0]), Vec2::new(fx.d[1], fy.d[1])],
        film: Vec2::new(fx.v, fy.v),
        trace,
    })
}

/// Chord point `p0` moved along the unit normal `m` onto the curve (at
/// most two cells away), with φ's derivatives there.
fn onto_curve(
    scene: &Scene,
    grid: &Disc,
    target: Target,
    p0: Vec2,
    m: Vec2,
    stats: &mut BoundaryStats,
) -> Option<Local> {
    let tolerance = NEWTON_TOLERANCE_PX * grid.step / STEP_PX;
    let mut s = 0.0f32;
    for _ in 0..NEWTON_STEPS {
        let at = local(scene, grid, target, p0 + m * s, stats)?;
        let slope = at.grad.dot(m);
        if !(slope.abs() > 0.0 && slope.is_finite()) {
            return None;
        }
        let step = -at.value / slope;
        if step.abs() <= tolerance {
            return Some(at);
        }
        s += step;
        let near = s.abs() <= 2.0 * grid.step;
        if !near {
            return None;
        }
    }
    None
}

/// The curves seen in curved mirrors and through glass that can move on
/// the film for these parameters, under Whitted: per sphere or ellipsoid
/// that reflects, and again per one that transmits, the other smooth
/// objects' silhouettes, the planes' horizons and the smooth objects'
/// shadow edges from each point light, found on the mirror's grid; each
/// with about `density` samples per pixel of length.
pub fn curved_jobs<const K: usize>(
    view: &DualScene<'_, K>,
    params: &[ParamId],
    integrator: &IntegratorKind,
    density: f32,
    stats: &mut BoundaryStats,
) -> Vec<CurvedJob> {
    let scene = view.scene();
    if !matches!(integrator, IntegratorKind::Whitted) {
        return Vec::new();
    }
    let camera = params.iter().any(is_camera);
    let any_object = (0..scene.objects.len() as u32).any(|o| view.moves(o));
    let object = |prim: u32| scene.prims[prim as usize].object;
    let prims = |keep: fn(&Shape) -> bool| {
        (0..scene.prims.len() as u32)
            .filter(move |&p| keep(&scene.prims[p as usize].shape))
            .collect::<Vec<u32>>()
    };
    let smooth = prims(|s| matches!(s, Shape::Sphere(_) | Shape::Ellipsoid(_)));
    let planes = prims(|s| matches!(s, Shape::Plane(_)));
    let mut jobs = Vec::new();
    for chain in chains(scene) {
        // The index bends what glass shows; a mirror's does nothing.
        let moves = |step: &chain::Step| {
            let object = object(step.prim());
            let ior = &view.material(object).ior;
            let ior_moves =
                matches!(step, chain::Step::Through { .. }) && ior.d.iter().any(|&d| d != 0.0);
            view.moves(object) || ior_moves
        };
        let all = camera || chain.steps().iter().any(moves);
        let last = chain.last();
        let mut targets = Vec::new();
        for &s in &smooth {
            if s != last && (all || view.moves(object(s))) {
                targets.push(Target::Silhouette(s));
            }
        }
        for &p in &planes {
            if p != last && (all || view.moves(object(p))) {
                targets.push(Target::Horizon(p));
            }
        }
        for light in 0..scene.lights.len() {
            for &occluder in &smooth {
                if all || any_object || light_moves(view, light) {
                    targets.push(Target::Shadow { light, occluder });
                }
            }
        }
        if !targets.is_empty() {
            mirror_jobs(scene, chain, &targets, density, stats, &mut jobs);
        }
    }
    jobs
}

/// The jobs of `targets` seen along `chain`, pushed on `jobs`.
fn mirror_jobs(
    scene: &Scene,
    chain: Chain,
    targets: &[Target],
    density: f32,
    stats: &mut BoundaryStats,
    jobs: &mut Vec<CurvedJob>,
) {
    let Some(grid) = Grid::over(scene, chain, stats) else {
        return;
    };
    let grid = &grid;
    let found: Vec<(Vec<[Vec2; 2]>, u64)> = targets
        .par_iter()
        .map(|&target| grid.chords(scene, target))
        .collect();
    for (&target, (chords, rays)) in targets.iter().zip(found) {
        stats.light_rays += rays;
        if chords.is_empty() {
            continue;
        }
        // Samples by the chords' film length (measured on their ends).
        let frame = scene.camera.frame();
        let film = |p: Vec2| grid.disc.cap.film(&frame, grid.disc.size, (p.x, p.y));
        let on_film: f32 = chords
            .iter()
            .filter_map(|[a, b]| Some((film(*a)?.0 - film(*b)?.0, film(*a)?.1 - film(*b)?.1)))
            .map(|(dx, dy)| dx.hypot(dy))
            .sum();
        let ends: Vec<f32> = chords
            .iter()
            .scan(0.0f32, |sum, [a, b]| {
                *sum += (*b - *a).length();
                Some(*sum)
            })
            .collect();
        match target {
            Target::Shadow { .. } => stats.shadow_curves += 1,
            _ => stats.primary_curves += 1,
        }
        jobs.push(CurvedJob {
            disc: grid.disc,
            target,
            chords,
            ends,
            samples: (density * on_film).ceil().clamp(2.0, 1e7) as u32,
        });
    }
}

/// Draw `job.samples` points on a curve seen in a curved mirror and
/// return what they add to each pixel (the first `n` of the K
/// parameters), with the work done.
pub(crate) fn sample_curved<const K: usize>(
    view: &DualScene<'_, K>,
    job: &CurvedJob,
    n: usize,
    integrator: &IntegratorKind,
    seed: u64,
) -> CurveResult<K> {
    let scene = view.scene();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let grid = &job.disc;
    let setup = Setup {
        frame: view.frame(),
        size: (w, h),
        geometry: |p: u32| view.geometry(p),
        light: |i: usize| view.point_light(i).0,
        ior: |p: u32| view.material(scene.prims[p as usize].object).ior,
    };
    let mut stats = BoundaryStats {
        samples: u64::from(job.samples),
        ..Default::default()
    };
    let total = job.ends.last().copied().unwrap_or(0.0);
    let mut rng = SplitMix64(seed);
    let mut sums = SparseSums::<K>::new(n);
    for index in 0..job.samples {
        let pick = rng.next_f32() * total;
        let c = job.ends.partition_point(|&e| e <= pick);
        let u = rng.next_f32();
        let Some(&[a, b]) = job.chords.get(c) else {
            continue;
        };
        let chord = b - a;
        let len = chord.length();
        let m = chord.perp() / len;
        let Some(at) = onto_curve(scene, grid, job.target, a + chord * u, m, &mut stats) else {
            continue;
        };
        let x = at.film;
        if !(x.x >= 0.0 && x.y >= 0.0 && x.x < w as f32 && x.y < h as f32) {
            continue;
        }
        let film = (Dual::from_f32(x.x), Dual::from_f32(x.y));
        let Some(phi) = setup.phi(film, grid, job.target, &at.trace) else {
            continue;
        };
        // dx/du on the film, over the chord's share of all the chords.
        let along = chord - m * (at.grad.dot(chord) / at.grad.dot(m));
        let [c0, c1] = at.jacobian;
        let weight = total * (c0 * along.x + c1 * along.y).length() / len;
        let g = at.film_gradient();
        let gn = g.length();
        let speed: Vec<f32> = (0..n).map(|k| -phi.d[k] / gn * weight).collect();
        if !speed.iter().all(|v| v.is_finite()) || speed.iter().all(|&v| v == 0.0) {
            continue;
        }
        // Both sides must follow the chain: within the offset of a rim
        // on the way (where the grid reaches) one would see past it, and
        // the jump would be the rim's.
        let (ox, oy) = offset((g.x, g.y), gn);
        let follows = |s: f32| trace(scene, (x.x + s * ox, x.y + s * oy), &grid.chain).is_some();
        stats.light_rays += 2 * grid.chain.rays();
        if !(follows(-1.0) && follows(1.0)) {
            continue;
        }
        let (pixel, ctx) = landed(&mut stats, (x.x, x.y), w, index, seed);
        let jump = jump(scene, integrator, (x.x, x.y), (ox, oy), &ctx, None);
        sums.add(pixel, jump, &speed);
    }
    CurveResult {
        sums,
        samples: job.samples,
        stats,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gap is the distance from the line to the sphere's surface, and
    /// an ellipsoid's is zero exactly where the line touches it.
    #[test]
    fn the_gap_is_zero_where_a_line_touches() {
        let sphere = ShapeR::<f32>::Sphere {
            centre: V3::new(1.0, 2.0, 3.0),
            radius: 0.5,
        };
        let d = V3::new(1.0, 0.0, 0.0);
        let (g, along) = gap(V3::new(-2.0, 2.0, 3.5), d, &sphere).unwrap();
        assert!(g.abs() < 1e-6 && (along - 3.0).abs() < 1e-6);
        let (g, _) = gap(V3::new(-2.0, 2.0, 4.0), d, &sphere).unwrap();
        assert!((g - 0.5).abs() < 1e-6);
        // The unit sphere stretched by 2 along y: the line y = 2 touches.
        let to_unit =
            crate::math::M3::from_mat3(glam::Mat3::from_diagonal(glam::Vec3::new(1.0, 0.5, 1.0)));
        let ellipsoid = ShapeR::Ellipsoid {
            centre: V3::zero(),
            to_unit,
        };
        let (g, _) = gap(V3::new(-5.0, 2.0, 0.0), d, &ellipsoid).unwrap();
        assert!(g.abs() < 1e-6);
        let (g, _) = gap(V3::new(-5.0, 1.0, 0.0), d, &ellipsoid).unwrap();
        assert!(g < -0.1);
    }
}
