//! Adaptive supersampling (Whitted 1980, with Mitchell's 1987 contrast
//! measure): spend rays where the image changes.
//!
//! 1. Trace one ray through every pixel corner: a (W+1)×(H+1) lattice, so
//!    each pixel costs about one ray and neighbours share corners.
//! 2. For each pixel, look at its square's four corner values. If their
//!    contrast exceeds the threshold in any channel, split the square in
//!    four — five new rays: the four edge midpoints and the centre — and
//!    look at each quarter the same way, down to `depth` levels.
//! 3. The pixel is the mean over its leaf squares (each weighted by its
//!    area) of their four corners' mean: the trapezoid rule over the pixel.
//!
//! Contrast per channel is Mitchell's (max − min)/(max + min) over the four
//! corners, which tracks perceived difference better than absolute
//! differences (the eye sees ratios); a channel whose corners are all
//! (near) zero has none.
//!
//! Every point lies on the fine lattice of spacing 2^−depth pixels, and its
//! value is a pure function of its lattice coordinates (they key the
//! integrator's random numbers), so a midpoint shared by two pixels that
//! both refine has the same value in both, and the image does not depend on
//! the thread count. A point is traced once per pixel (siblings share their
//! common edge's points), and a pixel takes over the points its left
//! neighbour traced on their common edge (a row is one thread's, left to
//! right); points on the edge between two rows are traced by both rows when
//! both refine there. A pixel's count is every ray it traced, its top-left
//! corner included (the last row and column also take the lattice's extra
//! corners), so the counts sum to the rays spent.
//!
//! The film's per-pixel variance is left at zero: the leaf values are not
//! independent samples of one distribution.

use super::{Integrator, SampleContext};
use crate::film::{Film, PixelStats};
use crate::math::Color;
use crate::scene::Scene;
use crate::stats::{RenderStats, Stats};
use rayon::prelude::*;

/// Render the scene with adaptive supersampling; returns the film (each
/// pixel's count = rays it traced) and each pixel's statistics.
pub fn render<I, S>(scene: &Scene, integrator: &I, threshold: f32, depth: u32) -> (Film, Vec<S>)
where
    I: Integrator,
    S: RenderStats,
{
    let (w, h) = (scene.camera.width, scene.camera.height);
    let tracer = Tracer {
        scene,
        integrator,
        threshold,
        depth,
    };
    let step = 1u32 << depth;
    // 1. The corner lattice, row by row.
    let lattice: Vec<Vec<(Color, S)>> = (0..=h)
        .into_par_iter()
        .map(|j| {
            (0..=w)
                .map(|i| {
                    let mut stats = S::default();
                    let c = tracer.trace(i * step, j * step, &mut stats);
                    (c, stats)
                })
                .collect()
        })
        .collect();
    // 2–3. Refine each pixel; a row is one thread's, left to right, so a
    // pixel takes over the points its left neighbour traced on their
    // common edge.
    let mut film = Film::new(w, h);
    super::progress::announce(u64::from(h));
    let per_row: Vec<Vec<S>> = film
        .pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .map(|(y, row)| {
            let y = y as u32;
            let mut stats_row = Vec::with_capacity(row.len());
            let mut grid = PixelGrid::new(step);
            for (x, pixel) in row.iter_mut().enumerate() {
                let x = x as u32;
                let mut stats = S::default();
                let corner = |i: u32, j: u32| lattice[j as usize][i as usize].0;
                grid.start(
                    (x * step, y * step),
                    x > 0,
                    [
                        corner(x, y),
                        corner(x + 1, y),
                        corner(x, y + 1),
                        corner(x + 1, y + 1),
                    ],
                );
                let mean = tracer.refine(&mut grid, 0, 0, step, 0, &mut stats);
                let mut count = grid.traced;
                // The lattice rays this pixel owns: its top-left corner, and
                // the far corners along the last column and row.
                let owned = [
                    (x, y, true),
                    (x + 1, y, x + 1 == w),
                    (x, y + 1, y + 1 == h),
                    (x + 1, y + 1, x + 1 == w && y + 1 == h),
                ];
                for (i, j, mine) in owned {
                    if mine {
                        count += 1;
                        stats += lattice[j as usize][i as usize].1.clone();
                    }
                }
                *pixel = PixelStats {
                    mean,
                    m2: Color::ZERO,
                    count,
                };
                stats_row.push(stats);
            }
            super::progress::row_done();
            stats_row
        })
        .collect();
    (film, per_row.into_iter().flatten().collect())
}

struct Tracer<'a, I> {
    scene: &'a Scene,
    integrator: &'a I,
    threshold: f32,
    depth: u32,
}

impl<I: Integrator> Tracer<'_, I> {
    /// The radiance through fine-lattice point (`fx`, `fy`), at film
    /// position (fx, fy)·2^−depth pixels.
    fn trace<S: Stats>(&self, fx: u32, fy: u32, stats: &mut S) -> Color {
        let scale = 1.0 / (1u32 << self.depth) as f32;
        let ray = self
            .scene
            .camera
            .generate_ray(fx as f32 * scale, fy as f32 * scale);
        let ctx = SampleContext {
            px: fx,
            py: fy,
            index: 0,
            seed: self.scene.settings.seed,
        };
        self.integrator.radiance(self.scene, &ray, &ctx, stats)
    }

    // ANCHOR: refine
    /// The mean over the square of side `size` (fine units) whose top-left
    /// point is (`lx`, `ly`) in the pixel's `grid`, at subdivision `level`;
    /// its corners are in the grid already, new points are traced into it.
    fn refine<S: Stats>(
        &self,
        grid: &mut PixelGrid,
        lx: u32,
        ly: u32,
        size: u32,
        level: u32,
        stats: &mut S,
    ) -> Color {
        let (x1, y1) = (lx + size, ly + size);
        let corners = [
            grid.known(lx, ly),
            grid.known(x1, ly),
            grid.known(lx, y1),
            grid.known(x1, y1),
        ];
        if level >= self.depth || contrast(&corners) <= self.threshold {
            return (corners[0] + corners[1] + corners[2] + corners[3]) * 0.25;
        }
        let half = size / 2;
        let (xm, ym) = (lx + half, ly + half);
        for (px, py) in [(xm, ly), (lx, ym), (xm, ym), (x1, ym), (xm, y1)] {
            grid.trace_once(px, py, |fx, fy| self.trace(fx, fy, stats));
        }
        let next = level + 1;
        let q = [
            self.refine(grid, lx, ly, half, next, stats),
            self.refine(grid, xm, ly, half, next, stats),
            self.refine(grid, lx, ym, half, next, stats),
            self.refine(grid, xm, ym, half, next, stats),
        ];
        (q[0] + q[1] + q[2] + q[3]) * 0.25
    }
    // ANCHOR_END: refine
}

/// One pixel's points on the fine lattice, (step + 1)² of them, with what
/// has been traced so far; the left column carries over from the pixel to
/// the left.
struct PixelGrid {
    side: u32,
    /// Fine-lattice coordinates of the pixel's top-left corner.
    origin: (u32, u32),
    values: Vec<Option<Color>>,
    /// Rays traced for this pixel.
    traced: u32,
}

impl PixelGrid {
    fn new(step: u32) -> Self {
        let side = step + 1;
        Self {
            side,
            origin: (0, 0),
            values: vec![None; (side * side) as usize],
            traced: 0,
        }
    }

    fn index(&self, lx: u32, ly: u32) -> usize {
        (ly * self.side + lx) as usize
    }

    /// Begin the pixel at fine point `origin` with its four corners; with
    /// `share_left`, keep the right column of the previous pixel (the same
    /// points) as this one's left column.
    fn start(&mut self, origin: (u32, u32), share_left: bool, corners: [Color; 4]) {
        let n = self.side;
        for ly in 0..n {
            let carried = share_left
                .then(|| self.values[self.index(n - 1, ly)])
                .flatten();
            let row = self.index(0, ly);
            self.values[row..row + n as usize].fill(None);
            self.values[row] = carried;
        }
        let last = n - 1;
        for (v, (lx, ly)) in corners
            .into_iter()
            .zip([(0, 0), (last, 0), (0, last), (last, last)])
        {
            let i = self.index(lx, ly);
            self.values[i] = Some(v);
        }
        self.origin = origin;
        self.traced = 0;
    }

    /// A point that must have been traced (a corner of a square).
    fn known(&self, lx: u32, ly: u32) -> Color {
        self.values[self.index(lx, ly)].expect("square corners are traced before the square")
    }

    /// Trace point (`lx`, `ly`) unless it is already known; `trace` gets the
    /// fine-lattice coordinates.
    fn trace_once(&mut self, lx: u32, ly: u32, trace: impl FnOnce(u32, u32) -> Color) {
        let i = self.index(lx, ly);
        if self.values[i].is_none() {
            self.values[i] = Some(trace(self.origin.0 + lx, self.origin.1 + ly));
            self.traced += 1;
        }
    }
}

/// Mitchell's contrast, the largest over the three channels of
/// (max − min)/(max + min) among `values`. Channels whose values sum to
/// (almost) nothing have no contrast.
pub fn contrast(values: &[Color]) -> f32 {
    let mut c = 0.0f32;
    for ch in 0..3 {
        let (lo, hi) = values
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v[ch]), hi.max(v[ch]))
            });
        let sum = hi + lo;
        if sum > 1e-6 {
            c = c.max((hi - lo) / sum);
        }
    }
    c
}
