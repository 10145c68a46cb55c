//! S4's flood-fill irradiance cache: light spreads through the empty voxels
//! of a [`VoxelGrid`] by repeated neighbour averaging, and secondary rays
//! read it back instead of tracing further bounces.
//!
//! # What a voxel stores
//!
//! Each empty voxel stores a colour `I` in radiance units: the
//! cosine-weighted mean radiance arriving there (irradiance / π). A surface
//! of albedo ρ lit by it sends ρ·I, so the integrator multiplies the value
//! a lookup returns by the hit's albedo and ends the path. Opaque and
//! emissive voxels store nothing (always zero); emissive voxels are
//! constant sources.
//!
//! # One propagation step (S4)
//!
//! I(x, t+1) = α · Σ_{i ∈ 6 neighbours} I(i, t)·V(x, i) / 6,
//!
//! computed from one buffer into the other (ping-pong). V(x, i) = 0 when
//! neighbour i is opaque; instead an opaque or emissive neighbour i
//! contributes a constant source towards x,
//!
//! S(i→x) = Le_i + ρ_i · E_direct(face between i and x) [+ ρ_i · I(x, t)],
//!
//! its emission, plus its albedo times the direct light on the face it
//! turns to x (S4 injects sunlight this way; the direct-light function is
//! a parameter, see [`wall_light`]), plus, with
//! [`FloodFillConfig::surface_bounce`], the light of x itself reflected
//! back by the wall (the interreflection S4's scheme leaves out). Outside
//! the grid is black: light that leaves it is lost.
//!
//! # What α means
//!
//! With α = 1 one step is an average: away from sources and walls the sum
//! Σ_x I over an unbounded grid is conserved (each voxel hands 1/6 of its
//! value to each neighbour), so α = 1 is the energy-consistent value, and
//! the steady state is the discrete harmonic function with the sources as
//! boundary values: I = S next to a source, decaying away from it. α > 1
//! is a gain: every step creates (α − 1) of the light it moves. It stands
//! in for what the diffusion leaves out — the walls' interreflection and
//! the fact that transport carries light along straight lines with 1/r²
//! falloff, whereas a diffusion dilutes it by 1/6 per voxel in every
//! direction, which darkens anything a few voxels from a source. The price
//! is stability: with absorbing walls the averaging operator of an
//! n × n × n room has spectral radius λ = cos(π/(n+1)) ≈ 1 − π²/(2(n+1)²),
//! and the iteration diverges for α > 1/λ ≈ 1 + π²/(2(n+1)²) — about
//! 1.0012 for n = 64. S4's α = 2.43902 can only stay finite in an open
//! world where most light escapes, or when the stored values saturate
//! ([`FloodFillConfig::max_irradiance`]).
//!
//! With `surface_bounce` and α = 1 a closed room whose walls have albedo a
//! and emission Le reaches the uniform fixed point I = Le + a·I, i.e.
//! Le/(1 − a): the white-furnace value of the rendering equation.
//!
//! # Gamma-space averaging (S4)
//!
//! S4 averages neighbours in gamma space: I(x, t+1) = α·(Σ I_i^γ / 6)^{1/γ}
//! with γ = 2.2. Raising both sides to γ shows this is the linear update of
//! J = I^γ with gain α^γ: I(x,t+1)^γ = α^γ · Σ J_i / 6. So in gamma mode the
//! cache stores J and runs the same (fast) linear loop, and converts with
//! the 1/γ power only on lookup. Sources enter as S^γ (and the bounce term
//! as ρ^γ·J, which equals (ρ·I)^γ). Since the power mean exceeds the
//! arithmetic mean, gamma averaging brightens: at α = 1 the furnace fixed
//! point becomes Le/(1 − a^γ)^{1/γ}, not Le/(1 − a).

use super::voxel::{VoxelGrid, VoxelKind};
use super::GiError;
use crate::error::RangeError;
use crate::lighting;
use crate::math::{orthonormal_basis, Color, Vec3};
use crate::scene::Scene;
use rayon::prelude::*;

/// S4's tuned gain α.
pub const S4_ALPHA: f32 = 2.43902;

/// S4's gamma for gamma-space averaging.
pub const GAMMA: f32 = 2.2;

/// How lookups give up: at most this many half-voxel steps along the normal
/// looking for an empty voxel (a surface voxel is solid, and the nearest
/// empty voxel can be up to √3 voxels away from a tilted surface).
const MAX_MARCH: usize = 4;

/// How neighbour values are averaged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Averaging {
    /// The arithmetic mean.
    #[default]
    Linear,
    /// S4's: the mean of I^2.2, to the power 1/2.2.
    Gamma,
}

/// How a hit point reads the cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Lookup {
    /// S4's: the voxel of a random point in the normal-oriented half-ball
    /// of radius one voxel, pushed half a voxel off the surface.
    #[default]
    Hemisphere,
    /// Trilinear interpolation of the empty voxels around point +
    /// normal·½ voxel (opaque voxels get weight 0; weights renormalised).
    Trilinear,
}

/// Which threads a step runs on. Both give bit-identical grids: each voxel
/// is a pure function of the previous buffer, and residuals are summed per
/// z-slab, then over slabs in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Threads {
    /// The calling thread.
    #[default]
    One,
    /// The current rayon pool, one z-slab per task.
    Pool,
}

/// The settings of a cache.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloodFillConfig {
    /// Gain per step (see the module docs; 1 is energy-consistent).
    pub alpha: f32,
    pub averaging: Averaging,
    /// Walls reflect the light of the voxel in front of them (albedo ×
    /// its I) back into it; S4 does not.
    pub surface_bounce: bool,
    /// Stored values saturate here (per channel); infinity: no clamp.
    pub max_irradiance: f32,
    /// Steps [`FloodFill::frame`] runs (S4: one step every third frame).
    pub steps_per_frame: u32,
}

impl Default for FloodFillConfig {
    /// The energy-consistent scheme: α = 1, linear averaging, walls
    /// reflect, no clamp, one step per frame.
    fn default() -> Self {
        Self {
            alpha: 1.0,
            averaging: Averaging::Linear,
            surface_bounce: true,
            max_irradiance: f32::INFINITY,
            steps_per_frame: 1,
        }
    }
}

impl FloodFillConfig {
    /// S4's published scheme: α = 2.43902, gamma averaging, no wall
    /// reflection, no clamp.
    pub fn s4() -> Self {
        Self {
            alpha: S4_ALPHA,
            averaging: Averaging::Gamma,
            surface_bounce: false,
            ..Self::default()
        }
    }

    /// Check ranges; the message names the field.
    pub fn validate(&self) -> Result<(), RangeError> {
        if !(self.alpha > 0.0 && self.alpha.is_finite()) {
            return Err(RangeError::new("alpha", "positive and finite", self.alpha));
        }
        if self.max_irradiance.is_nan() || self.max_irradiance <= 0.0 {
            return Err(RangeError::new(
                "max_irradiance",
                "positive",
                self.max_irradiance,
            ));
        }
        if self.steps_per_frame == 0 {
            return Err(RangeError::new("steps_per_frame", "at least 1", 0));
        }
        Ok(())
    }
}

/// How much one step changed the irradiance I (not J = I^γ in gamma mode),
/// over every voxel and channel.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Residual {
    /// ‖I(t+1) − I(t)‖₂.
    pub l2: f64,
    /// max |I(t+1) − I(t)|.
    pub max: f64,
}

/// Area-light samples per lit wall face, by default.
pub const DEFAULT_WALL_LIGHT_SAMPLES: u32 = 16;

/// The direct light on the cache's wall faces, the one rule every builder
/// of a cache uses (the flood-fill render mode, the `floodfill` study,
/// [`FloodFill::from_scene`]): [`lighting::surface_direct`] — the point
/// lights a physical estimator sees (`whitted_only` stand-ins are not) and
/// `light_samples` light-only samples of the area lights. With
/// [`FloodFillConfig::surface_bounce`] the area lights are not sampled: the
/// emitters' light reaches the walls through the emissive voxels and comes
/// back by the walls' own bounce, and injecting it again would count the
/// first reflection twice. Point lights have no voxels, so they are always
/// injected.
pub fn wall_light<'a>(
    scene: &'a Scene,
    config: &FloodFillConfig,
    light_samples: u32,
) -> impl Fn(Vec3, Vec3) -> Color + 'a {
    let samples = if config.surface_bounce {
        0
    } else {
        light_samples
    };
    move |p, n| lighting::surface_direct(scene, p, n, samples)
}

/// The flood-fill cache: two irradiance buffers over the grid padded by a
/// black border of one voxel (so the stencil needs no bounds tests), the
/// gain of each voxel, and the constant terms of the voxels next to walls.
///
/// Layout, for speed (a 64³ step streams ~25 bytes per voxel): the buffers
/// are one array per colour channel (structure of arrays), so a row of the
/// stencil is a loop over plain `f32` slices the compiler vectorises; the
/// source and bounce terms, non-zero only for voxels touching a solid one
/// (about a tenth of them), are kept in a sparse list sorted by index and
/// applied per slab after the bulk rows.
#[derive(Clone, Debug)]
pub struct FloodFill {
    config: FloodFillConfig,
    origin: Vec3,
    voxel_size: f32,
    dims: [usize; 3],
    /// Padded dims (each + 2).
    pdims: [usize; 3],
    /// Per padded voxel: whether light may be stored (empty and inside).
    open: Vec<bool>,
    /// α/6 (α^γ/6 in gamma mode) for open voxels, 0 elsewhere.
    gain: Vec<f32>,
    /// Voxels with solid neighbours, sorted by padded index.
    walls: Vec<WallTerm>,
    /// `walls[wall_start[z]..wall_start[z + 1]]` lie in padded slab z.
    wall_start: Vec<usize>,
    /// I (or I^γ) per channel, current step.
    cur: [Vec<f32>; 3],
    /// The buffers the next step writes.
    next: [Vec<f32>; 3],
    /// Clamp in the stored domain.
    clamp: f32,
    steps: u64,
}

/// The constant terms of an open voxel with solid neighbours (stored
/// domain): Σ of their sources, and Σ of their albedos (zero without
/// surface bounce).
#[derive(Clone, Copy, Debug, PartialEq)]
struct WallTerm {
    index: usize,
    source: [f32; 3],
    bounce: [f32; 3],
}

impl FloodFill {
    /// Build a cache over `grid` with all empty voxels dark, its sources
    /// from the emissive voxels and from `direct(point, normal)`, the
    /// direct light on each face a solid voxel turns to an empty one
    /// (evaluated once per such face, at its centre, with the face's axis
    /// normal: voxel-world geometry, as S4's blocks).
    pub fn new(
        grid: &VoxelGrid,
        config: FloodFillConfig,
        direct: impl Fn(Vec3, Vec3) -> Color,
    ) -> Result<Self, GiError> {
        config.validate()?;
        let dims = grid.dims();
        let pdims = [dims[0] + 2, dims[1] + 2, dims[2] + 2];
        let len = pdims[0] * pdims[1] * pdims[2];
        let gamma = config.averaging == Averaging::Gamma;
        let dom = |c: Color| -> [f32; 3] {
            if gamma {
                [c.x.powf(GAMMA), c.y.powf(GAMMA), c.z.powf(GAMMA)]
            } else {
                c.to_array()
            }
        };
        let mut ff = Self {
            config,
            origin: grid.origin,
            voxel_size: grid.voxel_size,
            dims,
            pdims,
            open: vec![false; len],
            gain: vec![0.0; len],
            walls: Vec::new(),
            wall_start: Vec::new(),
            cur: std::array::from_fn(|_| vec![0.0; len]),
            next: std::array::from_fn(|_| vec![0.0; len]),
            clamp: if gamma {
                config.max_irradiance.powf(GAMMA)
            } else {
                config.max_irradiance
            },
            steps: 0,
        };
        let g = if gamma {
            config.alpha.powf(GAMMA)
        } else {
            config.alpha
        } / 6.0;
        let h = grid.voxel_size;
        for ((x, y, z), kind) in grid.kind.indexed_iter() {
            if *kind != VoxelKind::Empty {
                continue;
            }
            let i = ff.pidx([x, y, z]);
            ff.open[i] = true;
            ff.gain[i] = g;
            let centre = grid.voxel_centre([x, y, z]);
            let mut term = WallTerm {
                index: i,
                source: [0.0; 3],
                bounce: [0.0; 3],
            };
            let mut touches = false;
            for (axis, sign) in NEIGHBOURS {
                let mut nb = [x as isize, y as isize, z as isize];
                nb[axis] += sign;
                if nb[axis] < 0 || nb[axis] >= dims[axis] as isize {
                    continue;
                }
                let nb = [nb[0] as usize, nb[1] as usize, nb[2] as usize];
                if !grid.kind[nb].is_solid() {
                    continue;
                }
                touches = true;
                // The face between the two voxels, seen from the solid one:
                // normal towards x, a hair into x against self-shadowing.
                let mut normal = Vec3::ZERO;
                normal[axis] = -sign as f32;
                let face = centre - (0.5 - 1e-4) * h * normal;
                let albedo = grid.albedo[nb];
                let s = dom(grid.emission[nb] + albedo * direct(face, normal));
                let r = dom(albedo);
                for c in 0..3 {
                    term.source[c] += s[c];
                    if config.surface_bounce {
                        term.bounce[c] += r[c];
                    }
                }
            }
            if touches {
                ff.walls.push(term);
            }
        }
        ff.walls.sort_by_key(|w| w.index);
        let slab = pdims[0] * pdims[1];
        ff.wall_start = (0..=pdims[2])
            .map(|z| ff.walls.partition_point(|w| w.index < z * slab))
            .collect();
        Ok(ff)
    }

    /// Voxelise `scene` and build a cache lit by its emitters and by the
    /// direct light of [`wall_light`] with `light_samples` area samples per
    /// face.
    pub fn from_scene(
        scene: &Scene,
        spec: &super::voxel::GridSpec,
        config: FloodFillConfig,
        light_samples: u32,
    ) -> Result<Self, GiError> {
        let grid = VoxelGrid::from_scene(scene, spec)?;
        Self::new(&grid, config, wall_light(scene, &config, light_samples))
    }

    /// The settings.
    pub fn config(&self) -> &FloodFillConfig {
        &self.config
    }

    /// Voxels along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Side of a voxel.
    pub fn voxel_size(&self) -> f32 {
        self.voxel_size
    }

    /// Steps run so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Index of voxel `i` in the padded buffers.
    #[inline]
    fn pidx(&self, i: [usize; 3]) -> usize {
        ((i[2] + 1) * self.pdims[1] + (i[1] + 1)) * self.pdims[0] + (i[0] + 1)
    }

    /// Run one propagation step.
    pub fn step(&mut self, threads: Threads) {
        self.advance::<false>(threads);
    }

    /// Run one step and report how much it changed I.
    pub fn step_with_residual(&mut self, threads: Threads) -> Residual {
        self.advance::<true>(threads)
    }

    /// Run [`FloodFillConfig::steps_per_frame`] steps, calling
    /// `after_step` after each (a progress count).
    pub fn frame(&mut self, threads: Threads, mut after_step: impl FnMut()) {
        for _ in 0..self.config.steps_per_frame {
            self.step(threads);
            after_step();
        }
    }

    fn advance<const RESIDUAL: bool>(&mut self, threads: Threads) -> Residual {
        let [px, py, pz] = self.pdims;
        let slab = px * py;
        let k = Kernel {
            cur: [&self.cur[0], &self.cur[1], &self.cur[2]],
            gain: &self.gain,
            walls: &self.walls,
            wall_start: &self.wall_start,
            px,
            py,
            clamp: self.clamp,
            inv_gamma: (self.config.averaging == Averaging::Gamma).then_some(1.0 / GAMMA),
        };
        // Slabs 0 and pz − 1 are the black border: never written.
        let [r, g, b] = &mut self.next;
        let (r, g, b) = (
            &mut r[slab..(pz - 1) * slab],
            &mut g[slab..(pz - 1) * slab],
            &mut b[slab..(pz - 1) * slab],
        );
        let partial: Vec<(f64, f64)> = match threads {
            Threads::One => r
                .chunks_mut(slab)
                .zip(g.chunks_mut(slab))
                .zip(b.chunks_mut(slab))
                .enumerate()
                .map(|(z, ((r, g), b))| k.slab::<RESIDUAL>(z + 1, [r, g, b]))
                .collect(),
            Threads::Pool => r
                .par_chunks_mut(slab)
                .zip(g.par_chunks_mut(slab))
                .zip(b.par_chunks_mut(slab))
                .enumerate()
                .map(|(z, ((r, g), b))| k.slab::<RESIDUAL>(z + 1, [r, g, b]))
                .collect(),
        };
        std::mem::swap(&mut self.cur, &mut self.next);
        self.steps += 1;
        let (sq, max) = partial
            .iter()
            .fold((0.0, 0.0f64), |(s, m), &(ps, pm)| (s + ps, m.max(pm)));
        Residual { l2: sq.sqrt(), max }
    }

    /// I of voxel `i` (zero for solid voxels).
    #[inline]
    pub fn voxel_irradiance(&self, i: [usize; 3]) -> Color {
        let j = self.pidx(i);
        self.to_irradiance([self.cur[0][j], self.cur[1][j], self.cur[2][j]])
    }

    #[inline]
    fn to_irradiance(&self, v: [f32; 3]) -> Color {
        let c = Color::from_array(v);
        match self.config.averaging {
            Averaging::Linear => c,
            Averaging::Gamma => c.powf(1.0 / GAMMA),
        }
    }

    /// Whether voxel `i` stores light (empty); false outside the grid.
    #[inline]
    pub fn is_open(&self, i: [isize; 3]) -> bool {
        (0..3).all(|k| i[k] >= 0 && (i[k] as usize) < self.dims[k])
            && self.open[self.pidx([i[0] as usize, i[1] as usize, i[2] as usize])]
    }

    /// The largest stored value of I over every voxel and channel (NaN
    /// values ignored; infinity once diverged).
    pub fn max_value(&self) -> f32 {
        let m = self
            .cur
            .iter()
            .flat_map(|c| c.iter().copied())
            .fold(0.0f32, f32::max);
        match self.config.averaging {
            Averaging::Linear => m,
            // x ↦ x^{1/γ} is increasing: the max commutes with it.
            Averaging::Gamma => m.powf(1.0 / GAMMA),
        }
    }

    /// The whole grid's I, indexed `[[x, y, z]]`.
    pub fn irradiance(&self) -> ndarray::Array3<Color> {
        ndarray::Array3::from_shape_fn((self.dims[0], self.dims[1], self.dims[2]), |(x, y, z)| {
            self.voxel_irradiance([x, y, z])
        })
    }

    /// The voxel containing `p` (signed: may lie outside the grid).
    #[inline]
    fn voxel_of(&self, p: Vec3) -> [isize; 3] {
        let g = ((p - self.origin) / self.voxel_size).floor();
        [g.x as isize, g.y as isize, g.z as isize]
    }

    // ANCHOR: lookup
    /// Irradiance for a secondary-ray hit at `p` with unit normal `n`
    /// (facing the side the ray came from). `u` are three uniform numbers
    /// in [0, 1) (only [`Lookup::Hemisphere`] uses them): the result is a
    /// pure function of its arguments. When no empty voxel is found within
    /// `MAX_MARCH` half-voxel steps along `n`, the nearest empty voxel in
    /// front of `p` within two voxels answers; black when there is none.
    pub fn lookup(&self, p: Vec3, n: Vec3, mode: Lookup, u: [f32; 3]) -> Color {
        let h = self.voxel_size;
        let mut q = match mode {
            Lookup::Hemisphere => {
                // Uniform direction in the hemisphere (cos θ uniform), at a
                // radius uniform in the half-ball's volume (r = h·∛u).
                let (t, b) = orthonormal_basis(n);
                let cos = u[0];
                let sin = (1.0 - cos * cos).max(0.0).sqrt();
                let phi = std::f32::consts::TAU * u[1];
                let d = sin * phi.cos() * t + sin * phi.sin() * b + cos * n;
                p + 0.5 * h * n + h * u[2].cbrt() * d
            }
            Lookup::Trilinear => p + 0.5 * h * n,
        };
        for _ in 0..=MAX_MARCH {
            let found = match mode {
                Lookup::Hemisphere => {
                    let i = self.voxel_of(q);
                    self.is_open(i).then(|| {
                        self.voxel_irradiance([i[0] as usize, i[1] as usize, i[2] as usize])
                    })
                }
                Lookup::Trilinear => self.trilinear(q),
            };
            if let Some(c) = found {
                return c;
            }
            q += 0.5 * h * n;
        }
        self.nearest_open_in_front(p, n).unwrap_or(Color::ZERO)
    }

    /// The I of the open voxel nearest to `p` whose centre lies in front
    /// of it (on the side `n` points to), among the 5×5×5 voxels around
    /// it: the fallback where marching along the normal stays in solid
    /// voxels — within a voxel of an edge or corner where two walls meet,
    /// the march runs along the other wall (without it, a cube room read
    /// black on a third of its walls).
    fn nearest_open_in_front(&self, p: Vec3, n: Vec3) -> Option<Color> {
        let g = ((p - self.origin) / self.voxel_size).floor();
        let b = [g.x as isize, g.y as isize, g.z as isize];
        let mut best: Option<(f32, [isize; 3])> = None;
        for dz in -2..=2isize {
            for dy in -2..=2isize {
                for dx in -2..=2isize {
                    let i = [b[0] + dx, b[1] + dy, b[2] + dz];
                    if !self.is_open(i) {
                        continue;
                    }
                    let centre = self.origin
                        + (Vec3::new(i[0] as f32, i[1] as f32, i[2] as f32) + 0.5)
                            * self.voxel_size;
                    if (centre - p).dot(n) <= 0.0 {
                        continue;
                    }
                    let d = (centre - p).length_squared();
                    if !best.is_some_and(|(bd, _)| d >= bd) {
                        best = Some((d, i));
                    }
                }
            }
        }
        best.map(|(_, i)| self.voxel_irradiance([i[0] as usize, i[1] as usize, i[2] as usize]))
    }
    // ANCHOR_END: lookup

    /// Trilinear interpolation of the open voxels' I between the eight
    /// voxel centres around `q`; `None` when all eight are solid or out.
    fn trilinear(&self, q: Vec3) -> Option<Color> {
        let g = (q - self.origin) / self.voxel_size - Vec3::splat(0.5);
        let base = g.floor();
        let f = g - base;
        let b = [base.x as isize, base.y as isize, base.z as isize];
        let (mut sum, mut wsum) = (Color::ZERO, 0.0f32);
        for corner in 0..8 {
            let o = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let i = [
                b[0] + o[0] as isize,
                b[1] + o[1] as isize,
                b[2] + o[2] as isize,
            ];
            if !self.is_open(i) {
                continue;
            }
            let mut w = 1.0;
            for k in 0..3 {
                w *= if o[k] == 1 { f[k] } else { 1.0 - f[k] };
            }
            sum += w * self.voxel_irradiance([i[0] as usize, i[1] as usize, i[2] as usize]);
            wsum += w;
        }
        // Below 1e-6 of the full weight the point sits on solid voxels'
        // centres; renormalising would amplify rounding.
        (wsum > 1e-6).then(|| sum / wsum)
    }
}

/// The six face neighbours: (axis, direction).
const NEIGHBOURS: [(usize, isize); 6] = [(0, -1), (0, 1), (1, -1), (1, 1), (2, -1), (2, 1)];

/// The read-only inputs of one step.
struct Kernel<'a> {
    cur: [&'a [f32]; 3],
    gain: &'a [f32],
    walls: &'a [WallTerm],
    wall_start: &'a [usize],
    px: usize,
    py: usize,
    clamp: f32,
    /// 1/γ in gamma mode (to measure residuals in I).
    inv_gamma: Option<f32>,
}

impl Kernel<'_> {
    /// Update padded z-slab `z` into `out` (that slab of the next buffers,
    /// per channel); returns the slab's (Σ squared change, max change) of I.
    #[inline]
    fn slab<const RESIDUAL: bool>(&self, z: usize, out: [&mut [f32]; 3]) -> (f64, f64) {
        let (px, py) = (self.px, self.py);
        let sz = px * py;
        let n = px - 2;
        let clamp = self.clamp;
        let base = z * sz;
        // ANCHOR: floodfill_update
        let (mut sq, mut max) = (0.0f64, 0.0f64);
        for (c, out) in out.into_iter().enumerate() {
            let cur = self.cur[c];
            for y in 1..py - 1 {
                // Voxel x = 1 of row y; every slice below has length n so the
                // loop has no bounds checks and vectorises.
                let i = base + y * px + 1;
                let (xm, xp) = (&cur[i - 1..i - 1 + n], &cur[i + 1..i + 1 + n]);
                let (ym, yp) = (&cur[i - px..i - px + n], &cur[i + px..i + px + n]);
                let (zm, zp) = (&cur[i - sz..i - sz + n], &cur[i + sz..i + sz + n]);
                let gain = &self.gain[i..i + n];
                let o = &mut out[y * px + 1..y * px + 1 + n];
                for k in 0..n {
                    // Opposite neighbours are added first, so mirroring the
                    // grid in any axis mirrors the result bit for bit.
                    let sum = (xm[k] + xp[k]) + (ym[k] + yp[k]) + (zm[k] + zp[k]);
                    // A select, not 0·sum: a diverged (infinite) sum must
                    // not turn solid voxels into NaN.
                    o[k] = if gain[k] > 0.0 {
                        (gain[k] * sum).min(clamp)
                    } else {
                        0.0
                    };
                }
            }
            // Voxels next to walls: the same sum plus their constant terms.
            for w in &self.walls[self.wall_start[z]..self.wall_start[z + 1]] {
                let i = w.index;
                let sum = (cur[i - 1] + cur[i + 1])
                    + (cur[i - px] + cur[i + px])
                    + (cur[i - sz] + cur[i + sz]);
                let v = self.gain[i] * (sum + (w.source[c] + w.bounce[c] * cur[i]));
                out[i - base] = v.min(clamp);
            }
            // ANCHOR_END: floodfill_update
            if RESIDUAL {
                for y in 1..py - 1 {
                    let i = base + y * px + 1;
                    let (old, new) = (&cur[i..i + n], &out[y * px + 1..y * px + 1 + n]);
                    for k in 0..n {
                        let d = match self.inv_gamma {
                            None => f64::from(new[k] - old[k]),
                            Some(e) => f64::from(new[k].powf(e) - old[k].powf(e)),
                        };
                        sq += d * d;
                        max = max.max(d.abs());
                    }
                }
            }
        }
        (sq, max)
    }
}
