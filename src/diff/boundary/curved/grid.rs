//! Finding a curve seen in a curved mirror: the grid over the part of the
//! mirror the eye sees and marching squares on it (see [`super`]).

use super::{trace, Disc, Setup, Target, Trace, Via, BISECTIONS, MAX_CELLS, STEP_PX};
use crate::camera::Frame;
use crate::diff::boundary::BoundaryStats;
use crate::math::{Real, M3, V3};
use crate::scene::{Scene, View};
use crate::shape::{Shape, ShapeR};
use glam::{Mat3, Vec2, Vec3};
use rayon::prelude::*;

/// The part of a mirror the eye sees, as a disc. In the mirror's
/// unit-sphere space (a sphere's scaled by 1/r, an ellipsoid's by its
/// `to_unit`) the eye is at e′, and the visible cap is the points
/// √(1 − X² − Y²)·w + X·u + Y·v with X² + Y² < `reach`² = 1 − 1/|e′|²,
/// w = e′/|e′| and (u, v) completing a basis. The rays leaving it are
/// smooth functions of (X, Y) up to the mirror's rim, where they are not
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
}

impl Cap {
    pub(super) fn of(scene: &Scene, mirror: u32) -> Option<Self> {
        let (centre, to_unit) = match &scene.prims[mirror as usize].shape {
            Shape::Sphere(s) => (s.centre, Mat3::from_diagonal(Vec3::splat(1.0 / s.radius))),
            Shape::Ellipsoid(e) => (e.centre, e.to_unit()),
            Shape::Plane(_) | Shape::Triangle(_) => return None,
        };
        let eye = to_unit * (scene.camera.frame().eye.value() - centre);
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
        })
    }

    /// Where the mirror point at `(x, y)` of the disc is on the film;
    /// `None` off the disc.
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
        let p = l(self.centre) + M3::from_mat3(self.from_unit).mul_vec(unit);
        frame.project(p, w, h)
    }
}

/// Where grid point `(i, j)` of a grid `cells` across lies on a disc of
/// radius `reach`: the square [−1, 1]² mapped onto the disc by
/// (u√(1 − v²/2), v√(1 − u²/2)), smooth and one to one, its sides onto
/// the rim (pulled in by 10⁻⁵ of the radius, where the rays still meet
/// the mirror). So the cells tile the whole disc, up to its rim, where
/// the film squeezes what the mirror shows; a square grid cut by the
/// circle lost the arcs in its cells across the rim (the mirror test's
/// pixels there passed 0.5–1 % less often).
fn on_disc(reach: f32, cells: usize, i: f32, j: f32) -> Vec2 {
    let (u, v) = (2.0 * i / cells as f32 - 1.0, 2.0 * j / cells as f32 - 1.0);
    let r = reach * (1.0 - 1e-5);
    Vec2::new(
        u * (1.0 - 0.5 * v * v).sqrt(),
        v * (1.0 - 0.5 * u * u).sqrt(),
    ) * r
}

/// The grid over a mirror's disc ([`Cap`]): its mirror, the film size,
/// its step (about [`STEP_PX`] on the film at the disc's centre), cells
/// across (and down), and per grid point ([`on_disc`]) the rays traced
/// there.
pub(super) struct Grid {
    pub(super) disc: Disc,
    cells: usize,
    points: Vec<Option<Trace>>,
}

impl Grid {
    /// The grid over `mirror`'s disc, for the rays that leave it `via`;
    /// `None` where the eye is inside the mirror or part of its rim is
    /// behind the eye.
    pub(super) fn over(
        scene: &Scene,
        mirror: u32,
        via: Via,
        stats: &mut BoundaryStats,
    ) -> Option<Self> {
        let cap = Cap::of(scene, mirror)?;
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
        let cells = ((2.0 * cap.reach / step).ceil() as usize).clamp(2, MAX_CELLS);
        let step = 2.0 * cap.reach / cells as f32;
        let points: Vec<Option<Trace>> = (0..=cells)
            .into_par_iter()
            .flat_map_iter(|j| {
                let cap = &cap;
                (0..=cells).map(move |i| {
                    let p = on_disc(cap.reach, cells, i as f32, j as f32);
                    let (x, y) = cap.film(&frame, size, (p.x, p.y))?;
                    trace(scene, (x, y), mirror, via)
                })
            })
            .collect();
        stats.light_rays += via.rays() * points.iter().flatten().count() as u64;
        Some(Self {
            disc: Disc {
                mirror,
                via,
                size,
                cap,
                step,
            },
            cells,
            points,
        })
    }

    fn point(&self, i: usize, j: usize) -> Vec2 {
        on_disc(self.disc.cap.reach, self.cells, i as f32, j as f32)
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
            ior: View::material(scene, scene.prims[self.disc.mirror as usize].object).ior,
        };
        let mut rays = 0u64;
        let mut at = |p: Vec2| {
            let (x, y) = self.disc.cap.film(&frame, self.disc.size, (p.x, p.y))?;
            rays += self.disc.via.rays();
            let t = trace(scene, (x, y), self.disc.mirror, self.disc.via)?;
            setup.phi_along(t.out, target, &t)
        };
        let n = self.cells;
        let values: Vec<Option<f32>> = self
            .points
            .iter()
            .map(|p| {
                let t = p.as_ref()?;
                setup.phi_along(t.out, target, t)
            })
            .collect();
        let value = |i: usize, j: usize| values[j * (n + 1) + i];
        // The crossing on the side from grid point (i, j) to (i2, j2).
        let mut side = |(i, j): (usize, usize), (i2, j2): (usize, usize)| {
            let (fa, fb) = (value(i, j)?, value(i2, j2)?);
            if (fa < 0.0) == (fb < 0.0) {
                return None;
            }
            let (a, b) = (self.point(i, j), self.point(i2, j2));
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
            let zero = lo.1.abs() + hi.1.abs() <= 1e-3 * (fa.abs() + fb.abs());
            zero.then(|| a + (b - a) * (0.5 * (lo.0 + hi.0)))
        };
        let across: Vec<Option<Vec2>> = (0..=n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .map(|(i, j)| side((i, j), (i + 1, j)))
            .collect();
        let down: Vec<Option<Vec2>> = (0..n)
            .flat_map(|j| (0..=n).map(move |i| (i, j)))
            .map(|(i, j)| side((i, j), (i, j + 1)))
            .collect();
        let mut chords = Vec::new();
        for j in 0..n {
            for i in 0..n {
                // The cell's sides in turn: top, right, bottom, left.
                let sides = [
                    across[j * n + i],
                    down[j * (n + 1) + i + 1],
                    across[(j + 1) * n + i],
                    down[j * (n + 1) + i],
                ];
                let found: Vec<Vec2> = sides.iter().flatten().copied().collect();
                match found.len() {
                    2 => chords.push([found[0], found[1]]),
                    4 => {
                        // A saddle: the centre's sign says which corners
                        // the curve cuts off.
                        let (ci, cj) = (i as f32 + 0.5, j as f32 + 0.5);
                        let centre = on_disc(self.disc.cap.reach, self.cells, ci, cj);
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
