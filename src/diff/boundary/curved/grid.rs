//! Finding a curve seen in a curved mirror: the grid over the part of the
//! mirror the eye sees and marching squares on it (see [`super`]).

use super::chain::{trace, Chain, Trace, MAX_STEPS};
use super::{
    Disc, Setup, Target, BISECTIONS, COARSE_CELLS, MAX_CELLS, MIN_CELLS, STEP_PX, ZERO_SHRINK,
};
use crate::camera::Frame;
use crate::diff::boundary::{BoundaryStats, OFFSET_PX};
use crate::math::{Real, M3, V3};
use crate::scene::{Scene, View};
use crate::shape::{Shape, ShapeR};
use glam::{Mat3, Vec2, Vec3};
use rayon::prelude::*;

/// The part of a chain's first curved object (a mirror or glass) that
/// the eye sees, as a disc. The planes the chain reflects off before it
/// are folded into the eye: its mirror image in each in turn sees the
/// object as the eye sees it through them. In the object's unit-sphere
/// space (a sphere's scaled by 1/r, an ellipsoid's by its `to_unit`) that
/// eye is at e′, and the visible cap is the points
/// √(1 − X² − Y²)·w + X·u + Y·v with X² + Y² < `reach`² = 1 − 1/|e′|²,
/// w = e′/|e′| and (u, v) completing a basis. The rays leaving it are
/// smooth functions of (X, Y) up to the object's rim, where they are not
/// of the film position (the film squeezes the rim's neighbourhood), so
/// the grid is laid out in (X, Y).
#[derive(Clone, Copy)]
pub(super) struct Cap {
    pub(super) centre: Vec3,
    pub(super) from_unit: Mat3,
    pub(super) w: Vec3,
    pub(super) u: Vec3,
    pub(super) v: Vec3,
    pub(super) reach: f32,
    /// The planes before the object (point, unit normal), the first
    /// `folds` in use.
    planes: [(Vec3, Vec3); MAX_STEPS],
    folds: usize,
}

/// The mirror image of `p` in the plane through `q` with unit normal `n`.
fn fold(p: Vec3, (q, n): (Vec3, Vec3)) -> Vec3 {
    p - 2.0 * (p - q).dot(n) * n
}

impl Cap {
    pub(super) fn of(scene: &Scene, chain: &Chain) -> Option<Self> {
        let first = chain.first_curved(scene)?;
        let mut planes = [(Vec3::ZERO, Vec3::ZERO); MAX_STEPS];
        let mut eye = scene.camera.frame().eye.value();
        for (k, step) in chain.steps()[..first].iter().enumerate() {
            let Shape::Plane(p) = &scene.prims[step.prim() as usize].shape else {
                return None;
            };
            planes[k] = (p.point, p.normal.normalize());
            eye = fold(eye, planes[k]);
        }
        let prim = chain.steps()[first].prim();
        let (centre, to_unit) = match &scene.prims[prim as usize].shape {
            Shape::Sphere(s) => (s.centre, Mat3::from_diagonal(Vec3::splat(1.0 / s.radius))),
            Shape::Ellipsoid(e) => (e.centre, e.to_unit()),
            Shape::Plane(_) | Shape::Triangle(_) => return None,
        };
        let eye = to_unit * (eye - centre);
        let d = eye.length();
        if !(d > 1.0 && to_unit.determinant().abs() > 0.0) {
            return None;
        }
        let w = eye / d;
        let (u, v) = w.any_orthonormal_pair();
        Some(Self {
            centre,
            from_unit: to_unit.inverse(),
            w,
            u,
            v,
            reach: (1.0 - 1.0 / (d * d)).sqrt(),
            planes,
            folds: first,
        })
    }

    /// Where the point at `(x, y)` of the disc is on the film (seen
    /// through the planes before it); `None` off the disc.
    pub(super) fn film<R: Real>(
        &self,
        frame: &Frame<R>,
        (w, h): (u32, u32),
        (x, y): (R, R),
    ) -> Option<(R, R)> {
        let r2 = x * x + y * y;
        let on_disc = r2.value() < self.reach * self.reach;
        if !on_disc {
            return None;
        }
        let l = |v: Vec3| V3::<R>::from_vec3(v);
        let unit = l(self.w) * (R::one() - r2).sqrt() + l(self.u) * x + l(self.v) * y;
        let mut p = l(self.centre) + M3::from_mat3(self.from_unit).mul_vec(unit);
        for &(q, n) in self.planes[..self.folds].iter().rev() {
            let d = (p - l(q)).dot(l(n));
            p = p - l(n) * (d + d);
        }
        frame.project(p, w, h)
    }
}

/// Where grid point `(i, j)` of a grid `cells` across lies on a disc of
/// radius `reach`: the square [−1, 1]² mapped onto the disc by
/// (u√(1 − v²/2), v√(1 − u²/2)), smooth and one to one, its sides onto
/// the rim pulled in by the fraction `rim` of the radius ([`rim_pull`]).
/// So the cells tile the whole disc, up to its rim, where the film
/// squeezes what the mirror shows; a square grid cut by the circle lost
/// the arcs in its cells across the rim (the mirror test's pixels there
/// passed 0.5–1 % less often).
fn on_disc(reach: f32, rim: f32, cells: usize, i: f32, j: f32) -> Vec2 {
    let (u, v) = (2.0 * i / cells as f32 - 1.0, 2.0 * j / cells as f32 - 1.0);
    let r = reach * (1.0 - rim);
    Vec2::new(
        u * (1.0 - 0.5 * v * v).sqrt(),
        v * (1.0 - 0.5 * u * u).sqrt(),
    ) * r
}

/// How far in (a fraction of the disc's radius `reach`) the grid's
/// outermost points lie, on a disc `radius` pixels in radius on the
/// film: where they are [`OFFSET_PX`]/32 inside the object's silhouette
/// on the film. Rays through points much closer to it are not the rays
/// through the disc point (a film position in f32 cannot say which side
/// of the silhouette it is on), and a sample of a curve running along
/// the rim closer than [`OFFSET_PX`] is refused anyway, since one side of
/// its jump would see past the object. In unit-sphere space, with the
/// eye at distance D = 1/√(1 − reach²), a point a fraction ρ in from the
/// disc's rim is seen at a viewing cosine of about ρD, and lies about
/// radius·(ρD)²/2 pixels inside the silhouette. The points used to lie
/// 10⁻⁵ in (10⁻⁷ pixel on S1's mirror at 32×32): their rays often missed
/// the object, the outermost ring of cells found no curve, and the
/// floor's shadows reflected in S1's mirror stopped short of where they
/// meet its rim. At [`OFFSET_PX`]/2 the glass's curves lost a little more
/// than that gained (S1's glass radius passed on 99.4 % of the pixels, not
/// 99.5 %).
fn rim_pull(reach: f32, radius: f32) -> f32 {
    let d = 1.0 / (1.0 - reach * reach).max(1e-12).sqrt();
    let rho = (OFFSET_PX / (16.0 * radius.max(1e-3))).sqrt() / d;
    rho.clamp(1e-5, 0.05)
}

/// The grid over a mirror's disc ([`Cap`]): its chain, the film size,
/// its step (about [`STEP_PX`] on the film at the disc's centre), cells
/// across the whole disc, how far in its outermost points lie
/// ([`rim_pull`]), the window of them laid out (from cell `lo`,
/// `n` cells across and down), and per grid point of the window
/// ([`on_disc`]) the rays traced there.
pub(super) struct Grid {
    pub(super) disc: Disc,
    cells: usize,
    rim: f32,
    lo: (usize, usize),
    n: (usize, usize),
    points: Vec<Option<Trace>>,
}

/// The window of a grid `cells` across that covers the coarse grid's
/// (`coarse` across) points in `seen` (index j·(coarse + 1) + i) with a
/// coarse cell to spare on every side: its first cell and its cells
/// across and down.
fn window(cells: usize, coarse: usize, seen: &[bool]) -> ((usize, usize), (usize, usize)) {
    let (mut lo, mut hi) = ((coarse, coarse), (0, 0));
    for (k, _) in seen.iter().enumerate().filter(|(_, &s)| s) {
        let (i, j) = (k % (coarse + 1), k / (coarse + 1));
        lo = (lo.0.min(i), lo.1.min(j));
        hi = (hi.0.max(i), hi.1.max(j));
    }
    let fine = |c: usize| c * cells / coarse;
    let span = |lo: usize, hi: usize| {
        let (a, b) = (fine(lo.saturating_sub(1)), fine((hi + 1).min(coarse)));
        (a, b - a)
    };
    let ((i0, ni), (j0, nj)) = (span(lo.0, hi.0), span(lo.1, hi.1));
    ((i0, j0), (ni, nj))
}

impl Grid {
    /// The grid over the disc of `chain`'s first curved object; `None`
    /// where the eye (folded) is inside it, part of its rim is behind the
    /// eye, or no point of a coarse grid follows the chain.
    pub(super) fn over(scene: &Scene, chain: Chain, stats: &mut BoundaryStats) -> Option<Self> {
        let cap = Cap::of(scene, &chain)?;
        let size = (scene.camera.width, scene.camera.height);
        let frame = scene.camera.frame();
        // The disc's radius on the film.
        let (cx, cy) = cap.film(&frame, size, (0.0, 0.0))?;
        let mut radius = 0.0f32;
        for k in 0..32 {
            let a = k as f32 * std::f32::consts::TAU / 32.0;
            let r = 0.999 * cap.reach;
            let (x, y) = cap.film(&frame, size, (r * a.cos(), r * a.sin()))?;
            radius = radius.max((x - cx).hypot(y - cy));
        }
        let step = STEP_PX * cap.reach / radius.max(STEP_PX);
        let cells = ((2.0 * cap.reach / step).ceil() as usize).clamp(MIN_CELLS, MAX_CELLS);
        let step = 2.0 * cap.reach / cells as f32;
        let rim = rim_pull(cap.reach, radius);
        // Most chains are seen nowhere, or on a small part of the disc:
        // a coarse grid first says where points follow the chain, and the
        // grid is laid out over those with a coarse cell to spare.
        let coarse = cells.min(COARSE_CELLS);
        let seen: Vec<bool> = (0..(coarse + 1) * (coarse + 1))
            .into_par_iter()
            .map(|k| {
                let (i, j) = ((k % (coarse + 1)) as f32, (k / (coarse + 1)) as f32);
                let p = on_disc(cap.reach, rim, coarse, i, j);
                let film = cap.film(&frame, size, (p.x, p.y));
                film.is_some_and(|xy| trace(scene, xy, &chain).is_some())
            })
            .collect();
        stats.light_rays += chain.rays() * seen.len() as u64;
        if !seen.iter().any(|&s| s) {
            return None;
        }
        let (lo, n) = window(cells, coarse, &seen);
        let points: Vec<Option<Trace>> = (0..=n.1)
            .into_par_iter()
            .flat_map_iter(|j| {
                let cap = &cap;
                (0..=n.0).map(move |i| {
                    let (i, j) = ((lo.0 + i) as f32, (lo.1 + j) as f32);
                    let p = on_disc(cap.reach, rim, cells, i, j);
                    let (x, y) = cap.film(&frame, size, (p.x, p.y))?;
                    trace(scene, (x, y), &chain)
                })
            })
            .collect();
        stats.light_rays += chain.rays() * points.iter().flatten().count() as u64;
        Some(Self {
            disc: Disc {
                chain,
                size,
                cap,
                step,
            },
            cells,
            rim,
            lo,
            n,
            points,
        })
    }

    /// Where the window's grid point `(i, j)` (or a cell's centre, at
    /// half indices) lies on the disc.
    fn point(&self, i: f32, j: f32) -> Vec2 {
        let (i, j) = (self.lo.0 as f32 + i, self.lo.1 as f32 + j);
        on_disc(self.disc.cap.reach, self.rim, self.cells, i, j)
    }

    /// The chords of `target`'s curve (on the disc) and the rays cast to
    /// place them.
    pub(super) fn chords(&self, scene: &Scene, target: Target) -> (Vec<[Vec2; 2]>, u64) {
        let frame = scene.camera.frame();
        let setup = Setup {
            frame: &frame,
            size: self.disc.size,
            geometry: |p: u32| ShapeR::of(&scene.prims[p as usize]),
            light: |i: usize| V3::from_vec3(scene.lights[i].position),
            ior: |p: u32| View::material(scene, scene.prims[p as usize].object).ior,
        };
        let mut rays = 0u64;
        let mut at = |p: Vec2| {
            let (x, y) = self.disc.cap.film(&frame, self.disc.size, (p.x, p.y))?;
            rays += self.disc.chain.rays();
            let t = trace(scene, (x, y), &self.disc.chain)?;
            setup.phi_along(t.out, target, &t)
        };
        let (ni, nj) = self.n;
        let values: Vec<Option<f32>> = self
            .points
            .iter()
            .map(|p| {
                let t = p.as_ref()?;
                setup.phi_along(t.out, target, t)
            })
            .collect();
        let value = |i: usize, j: usize| values[j * (ni + 1) + i];
        // The crossing on the side from grid point (i, j) to (i2, j2).
        let mut side = |(i, j): (usize, usize), (i2, j2): (usize, usize)| {
            let (fa, fb) = (value(i, j)?, value(i2, j2)?);
            if (fa < 0.0) == (fb < 0.0) {
                return None;
            }
            let (a, b) = (
                self.point(i as f32, j as f32),
                self.point(i2 as f32, j2 as f32),
            );
            let (mut lo, mut hi) = ((0.0f32, fa), (1.0f32, fb));
            for _ in 0..BISECTIONS {
                let mid = 0.5 * (lo.0 + hi.0);
                let f = at(a + (b - a) * mid)?;
                if (f < 0.0) == (fa < 0.0) {
                    lo = (mid, f);
                } else {
                    hi = (mid, f);
                }
            }
            // A zero, not a jump of φ (where the leaving ray's receiver
            // changes, say): the bracket's values have shrunk with it.
            let zero = lo.1.abs() + hi.1.abs() <= ZERO_SHRINK * (fa.abs() + fb.abs());
            zero.then(|| a + (b - a) * (0.5 * (lo.0 + hi.0)))
        };
        let across: Vec<Option<Vec2>> = (0..=nj)
            .flat_map(|j| (0..ni).map(move |i| (i, j)))
            .map(|(i, j)| side((i, j), (i + 1, j)))
            .collect();
        let down: Vec<Option<Vec2>> = (0..nj)
            .flat_map(|j| (0..=ni).map(move |i| (i, j)))
            .map(|(i, j)| side((i, j), (i, j + 1)))
            .collect();
        let mut chords = Vec::new();
        for j in 0..nj {
            for i in 0..ni {
                // The cell's sides in turn: top, right, bottom, left.
                let sides = [
                    across[j * ni + i],
                    down[j * (ni + 1) + i + 1],
                    across[(j + 1) * ni + i],
                    down[j * (ni + 1) + i],
                ];
                let found: Vec<Vec2> = sides.iter().flatten().copied().collect();
                match found.len() {
                    2 => chords.push([found[0], found[1]]),
                    4 => {
                        // A saddle: the centre's sign says which corners
                        // the curve cuts off.
                        let centre = self.point(i as f32 + 0.5, j as f32 + 0.5);
                        let (Some(centre), Some(corner)) = (at(centre), value(i, j)) else {
                            continue;
                        };
                        let s = found;
                        if (centre < 0.0) == (corner < 0.0) {
                            chords.extend([[s[0], s[1]], [s[2], s[3]]]);
                        } else {
                            chords.extend([[s[3], s[0]], [s[1], s[2]]]);
                        }
                    }
                    _ => {}
                }
            }
        }
        chords.retain(|[a, b]| (*b - *a).length() > 0.0);
        (chords, rays)
    }
}
