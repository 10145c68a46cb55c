//! Finding a curve seen in a curved mirror: the grid over the part of the
//! mirror the eye sees and marching squares on it (see [`super`]).

use super::chain::{trace, traced, Chain, CutOff, Trace, MAX_STEPS};
use super::{
    Disc, Setup, Target, BISECTIONS, COARSE_CELLS, MAX_CELLS, MIN_CELLS, REFINE_LEVELS, STEP_PX,
    ZERO_SHRINK,
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
/// `n` cells across and down), per grid point of the window
/// ([`on_disc`]) the rays traced there (or where they stop following the
/// chain), and the refined cells' leaves.
pub(super) struct Grid {
    pub(super) disc: Disc,
    cells: usize,
    rim: f32,
    lo: (usize, usize),
    n: (usize, usize),
    points: Vec<Result<Trace, CutOff>>,
    /// Per cell of the window (index j·n.0 + i), whether it is refined
    /// ([`Grid::refine`]), and the refined cells' sub-cells whose corners
    /// all follow the chain.
    refined: Vec<bool>,
    leaves: Vec<Leaf>,
}

/// A sub-cell of a refined cell: its first corner in grid indices
/// (fractional), its side in cells, and the rays traced at its corners
/// (i, j), (i + s, j), (i, j + s), (i + s, j + s).
struct Leaf {
    at: (f32, f32),
    side: f32,
    corners: [Trace; 4],
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

/// The rays traced at disc point `p` along `chain`, or where they stop
/// following it.
fn traced_at(
    scene: &Scene,
    cap: &Cap,
    size: (u32, u32),
    chain: &Chain,
    p: Vec2,
) -> Result<Trace, CutOff> {
    let frame = scene.camera.frame();
    let off = CutOff {
        later_curved: false,
    };
    let (x, y) = cap.film(&frame, size, (p.x, p.y)).ok_or(off)?;
    traced(scene, (x, y), chain)
}

/// Whether a cell with these corners has some that follow the chain and
/// one cut off at a later curved object's rim.
fn at_rim(corners: &[Result<Trace, CutOff>; 4]) -> bool {
    let follows = corners.iter().any(|c| c.is_ok());
    let rim = corners
        .iter()
        .any(|c| c.as_ref().err().is_some_and(|c| c.later_curved));
    follows && rim
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
        // Row-major, j·(n.0 + 1) + i, collected into one vector of the
        // right size (at most `GRID_POINTS`).
        let across = n.0 + 1;
        let points: Vec<Result<Trace, CutOff>> = (0..across * (n.1 + 1))
            .into_par_iter()
            .map(|k| {
                let (i, j) = ((lo.0 + k % across) as f32, (lo.1 + k / across) as f32);
                let p = on_disc(cap.reach, rim, cells, i, j);
                traced_at(scene, &cap, size, &chain, p)
            })
            .collect();
        stats.light_rays += chain.rays() * points.iter().flatten().count() as u64;
        let mut grid = Self {
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
            refined: Vec::new(),
            leaves: Vec::new(),
        };
        (grid.refined, grid.leaves) = grid.refine(scene, stats);
        Some(grid)
    }

    /// The window's cells where the chain is cut off at a later curved
    /// object's rim (some corners follow it, and one that does not is cut
    /// off there: [`CutOff`]), halved [`REFINE_LEVELS`] times where they
    /// still are: the sub-cells whose corners all follow the chain. What
    /// a curved object shows crowds against its rim, on the film and on
    /// the first curved object's disc alike, and a curve that runs along
    /// the rim closer than a cell lies in these cells only: S1's mirror,
    /// seen through its glass, shows the floor in its own shadow up to a
    /// tenth of a pixel from its rim (at 320×320 pixels), and moving the
    /// mirror's radius read +0.16 in the 10×10 pixels there without it
    /// (mean of four seeds), against −0.22 from central differences
    /// ([`REFINE_LEVELS`]). Cells cut off elsewhere (a plane's horizon,
    /// something in front of the first curved object) are not refined:
    /// with 5 levels, refining them too cost another 0.6 s of the boundary
    /// term on S1 at 32×32 pixels.
    fn refine(&self, scene: &Scene, stats: &mut BoundaryStats) -> (Vec<bool>, Vec<Leaf>) {
        let (ni, nj) = self.n;
        let corners_of = |i: usize, j: usize| {
            [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)]
                .map(|(a, b)| self.points[b * (ni + 1) + a])
        };
        let refined: Vec<bool> = (0..nj)
            .flat_map(|j| (0..ni).map(move |i| (i, j)))
            .map(|(i, j)| at_rim(&corners_of(i, j)))
            .collect();
        let cells: Vec<(usize, usize)> = (0..nj)
            .flat_map(|j| (0..ni).map(move |i| (i, j)))
            .filter(|&(i, j)| refined[j * ni + i])
            .collect();
        let found: Vec<(Vec<Leaf>, u64)> = cells
            .par_iter()
            .map(|&(i, j)| {
                let (mut leaves, mut traced) = (Vec::new(), 0u64);
                let at = (i as f32, j as f32);
                self.split(
                    scene,
                    at,
                    1.0,
                    corners_of(i, j),
                    0,
                    &mut leaves,
                    &mut traced,
                );
                (leaves, traced)
            })
            .collect();
        let mut leaves = Vec::new();
        for (l, traced) in found {
            stats.light_rays += self.disc.chain.rays() * traced;
            leaves.extend(l);
        }
        (refined, leaves)
    }

    /// The cell at `at` (grid indices) of side `side`, with the rays at
    /// its corners: a leaf where they all follow the chain, split in four
    /// where it is cut off at a later curved object's rim (down to
    /// [`REFINE_LEVELS`] levels), otherwise nothing.
    #[allow(clippy::too_many_arguments)]
    fn split(
        &self,
        scene: &Scene,
        at: (f32, f32),
        side: f32,
        corners: [Result<Trace, CutOff>; 4],
        level: u32,
        leaves: &mut Vec<Leaf>,
        traced: &mut u64,
    ) {
        if let [Ok(a), Ok(b), Ok(c), Ok(d)] = corners {
            leaves.push(Leaf {
                at,
                side,
                corners: [a, b, c, d],
            });
            return;
        }
        if !at_rim(&corners) || level == REFINE_LEVELS {
            return;
        }
        let mut trace_at = |i: f32, j: f32| {
            *traced += 1;
            let d = &self.disc;
            traced_at(scene, &d.cap, d.size, &d.chain, self.point(i, j))
        };
        let ((i, j), h) = (at, 0.5 * side);
        let top = trace_at(i + h, j);
        let right = trace_at(i + side, j + h);
        let bottom = trace_at(i + h, j + side);
        let left = trace_at(i, j + h);
        let centre = trace_at(i + h, j + h);
        let [c00, c10, c01, c11] = corners;
        let children = [
            ((i, j), [c00, top, left, centre]),
            ((i + h, j), [top, c10, centre, right]),
            ((i, j + h), [left, centre, c01, bottom]),
            ((i + h, j + h), [centre, right, bottom, c11]),
        ];
        for (at, corners) in children {
            self.split(scene, at, h, corners, level + 1, leaves, traced);
        }
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
        let rays = std::cell::Cell::new(0u64);
        let at = |p: Vec2| {
            let (x, y) = self.disc.cap.film(&frame, self.disc.size, (p.x, p.y))?;
            rays.set(rays.get() + self.disc.chain.rays());
            let t = trace(scene, (x, y), &self.disc.chain)?;
            setup.phi_along(t.out, target, &t)
        };
        let (ni, nj) = self.n;
        let values: Vec<Option<f32>> = self
            .points
            .iter()
            .map(|p| {
                let t = p.as_ref().ok()?;
                setup.phi_along(t.out, target, t)
            })
            .collect();
        let value = |i: usize, j: usize| values[j * (ni + 1) + i];
        // The crossing on the side from grid point (i, j) to (i2, j2)
        // (fractional indices), where φ is `fa` and `fb`.
        let side = |(i, j): (f32, f32), fa: Option<f32>, (i2, j2): (f32, f32), fb: Option<f32>| {
            let (fa, fb) = (fa?, fb?);
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
            let zero = lo.1.abs() + hi.1.abs() <= ZERO_SHRINK * (fa.abs() + fb.abs());
            zero.then(|| a + (b - a) * (0.5 * (lo.0 + hi.0)))
        };
        let grid_side = |(i, j): (usize, usize), (i2, j2): (usize, usize)| {
            let (a, b) = ((i as f32, j as f32), (i2 as f32, j2 as f32));
            side(a, value(i, j), b, value(i2, j2))
        };
        let across: Vec<Option<Vec2>> = (0..=nj)
            .flat_map(|j| (0..ni).map(move |i| (i, j)))
            .map(|(i, j)| grid_side((i, j), (i + 1, j)))
            .collect();
        let down: Vec<Option<Vec2>> = (0..nj)
            .flat_map(|j| (0..=ni).map(move |i| (i, j)))
            .map(|(i, j)| grid_side((i, j), (i, j + 1)))
            .collect();
        // Marching squares on the cell at `at` of side `s` whose sides
        // (top, right, bottom, left) cross the curve at `sides`, with φ
        // `corner` at its first corner.
        let cell = |(i, j): (f32, f32), s: f32, sides: [Option<Vec2>; 4], corner: Option<f32>| {
            let found: Vec<Vec2> = sides.iter().flatten().copied().collect();
            match found.len() {
                2 => vec![[found[0], found[1]]],
                4 => {
                    // A saddle: the centre's sign says which corners the
                    // curve cuts off.
                    let centre = self.point(i + 0.5 * s, j + 0.5 * s);
                    let (Some(centre), Some(corner)) = (at(centre), corner) else {
                        return Vec::new();
                    };
                    let f = found;
                    if (centre < 0.0) == (corner < 0.0) {
                        vec![[f[0], f[1]], [f[2], f[3]]]
                    } else {
                        vec![[f[3], f[0]], [f[1], f[2]]]
                    }
                }
                _ => Vec::new(),
            }
        };
        let mut chords = Vec::new();
        for j in 0..nj {
            for i in 0..ni {
                // A cell cut off at a later curved object's rim is found
                // in its leaves.
                if self.refined[j * ni + i] {
                    continue;
                }
                let sides = [
                    across[j * ni + i],
                    down[j * (ni + 1) + i + 1],
                    across[(j + 1) * ni + i],
                    down[j * (ni + 1) + i],
                ];
                chords.extend(cell((i as f32, j as f32), 1.0, sides, value(i, j)));
            }
        }
        for leaf in &self.leaves {
            let ((i, j), s) = (leaf.at, leaf.side);
            let f = leaf.corners.map(|t| setup.phi_along(t.out, target, &t));
            let p = [(i, j), (i + s, j), (i, j + s), (i + s, j + s)];
            let sides = [
                side(p[0], f[0], p[1], f[1]),
                side(p[1], f[1], p[3], f[3]),
                side(p[2], f[2], p[3], f[3]),
                side(p[0], f[0], p[2], f[2]),
            ];
            chords.extend(cell(leaf.at, s, sides, f[0]));
        }
        chords.retain(|[a, b]| (*b - *a).length() > 0.0);
        (chords, rays.get())
    }
}
