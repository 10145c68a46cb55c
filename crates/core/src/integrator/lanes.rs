//! The path tracer run on groups of [`LANES`] samples at once: the same
//! estimator as [`PathTracer`], with the same random numbers and the same
//! `f32` operations in the same order, so every sample's value is its value
//! there bit for bit (`crates/core/tests/path.rs` compares whole films and counters
//! bit for bit). What changes is the order of the work: the group's paths advance
//! in lockstep, one vertex at a time, and each step's arithmetic runs over
//! arrays with one entry per path, which the compiler turns into SIMD
//! instructions over the lanes (compiled a second time with AVX2 where the
//! CPU has it): the light sample's geometry and weights, the cosine warp
//! (whose sine and cosine are polynomials, not library calls), the shading
//! frame and BRDF direction, the rays' offset origins, the throughput and the
//! sums, and on a CPU with AVX-512 DQ the vertices' random numbers
//! (SplitMix64's 64-bit multiplies, which AVX2 lacks). Traversal, the
//! pixel sampler and camera, the random numbers elsewhere, the emitter
//! choice and the albedo stay one call per lane, to the one-sample loop's own functions.
//! The groups' code is generic over the accelerator: with `bvh8` on a CPU
//! with AVX2 it takes the tree's
//! [`InlineAvx2`](crate::accel::bvh::InlineAvx2) view, whose traversal
//! the compiler inlines into it (no call, no dispatch on the accelerator
//! kind, the tree's pointers kept in registers across the lanes' loop),
//! and with any other accelerator the scene's own.
//!
//! `make bench-peers` times it on the Cornell box beside Mitsuba 3
//! (`analysis/results/bench-peers/` holds a run).
//!
//! A lane whose path has ended keeps its slot and is masked out until the
//! group ends. Samples are taken in the scalar loop's order (pixel by pixel
//! along a row, sample index within a pixel) and added to the film in that
//! order, so the running means and variances match too.
//!
//! [`supported`] says which renders run here: the path tracer's estimator
//! (any strategy, any bounce count, Russian roulette on or off) on scenes
//! of triangles without interpolated normals, with a box filter and a
//! non-adaptive sampler. Every other render takes the one-sample-at-a-time
//! loop.

// Lane loops index several per-lane arrays by the lane.
#![allow(clippy::needless_range_loop)]

use super::bsdf::Bsdf;
use super::path::PathTracer;
use super::vertex::{
    pick_area_light, point_lights, sees_point_lights, vertex_key, vertex_numbers, VertexNumbers,
    DIMS_PER_VERTEX,
};
use super::{in_pool, render_rows, SampleContext};
use crate::accel::{Accel, Accelerator};
use crate::film::{Film, Filter, PixelStats};
use crate::light::AreaSampleR;
use crate::lighting::lambert_area_terms;
use crate::math::{Color, Ray, V3};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::shape::smooth::offset_origin;
use crate::shape::triangle::NO_MESH;
use crate::shape::{segment_to, Hit, HitR, PreparedRay, Shape};
use crate::stats::{RayKind, RenderStats, Stats};
use glam::Vec3;

/// Paths per group: two AVX2 registers of `f32` per quantity.
pub const LANES: usize = 16;

/// One `f32` per lane.
type F = [f32; LANES];
/// A vector per lane, one array per coordinate.
type V = [F; 3];

/// Whether [`render`] runs the path tracer on `scene` over groups (any
/// strategy, bounce count and roulette setting; see the module docs for
/// which scenes).
pub fn supported(scene: &Scene) -> bool {
    let triangles = scene.prims.iter().all(|p| match &p.shape {
        Shape::Triangle(t) => t.mesh == NO_MESH || scene.meshes[t.mesh as usize].normals.is_empty(),
        _ => false,
    });
    triangles
        && scene.unbounded.is_empty()
        && scene.settings.filter == Filter::Box
        && !matches!(scene.settings.sampler, Sampler::Adaptive { .. })
}

/// Render `scene` with `tracer`: over groups of [`LANES`] samples where
/// [`supported`], else with the one-sample loop ([`super::render`]). The
/// film and totals are that loop's, bit for bit.
pub fn render<S: RenderStats>(
    scene: &Scene,
    tracer: &PathTracer,
    threads: Option<usize>,
) -> (Film, S) {
    if !supported(scene) {
        return super::render(scene, tracer, threads);
    }
    if let Accelerator::Bvh8(bvh) = &scene.accel {
        if let Some(inline) = bvh.inline_avx2() {
            return render_with(scene, &inline, tracer, threads);
        }
    }
    render_with(scene, &scene.accel, tracer, threads)
}

/// [`render`] with the scene's accelerator as `accel`, whose queries
/// inline into the groups' code where `A` allows it.
fn render_with<S: RenderStats, A: Accel>(
    scene: &Scene,
    accel: &A,
    tracer: &PathTracer,
    threads: Option<usize>,
) -> (Film, S) {
    let normals = outward_normals(scene);
    #[cfg(target_arch = "x86_64")]
    let avx512 = avx512::available();
    #[cfg(not(target_arch = "x86_64"))]
    let avx512 = false;
    let lanes = Lanes {
        scene,
        accel,
        normals: &normals,
        point_lights: sees_point_lights(scene),
        avx512,
    };
    in_pool(threads, || {
        let mut film = Film::new(scene.camera.width, scene.camera.height);
        let (total, _) = render_rows(&mut film, |py, row, stats: &mut S| {
            render_row(&lanes, tracer, py, row, stats)
        });
        (film, total)
    })
}

/// Each triangle's unit outward normal ([`crate::shape::Triangle::normal`],
/// as [`Scene::hit_details`] computes it at every hit), by primitive (zero
/// for other shapes, which [`supported`] keeps out).
fn outward_normals(scene: &Scene) -> Vec<Vec3> {
    scene
        .prims
        .iter()
        .map(|p| match &p.shape {
            Shape::Triangle(t) => t.normal(),
            _ => Vec3::ZERO,
        })
        .collect()
}

/// What the groups read: the scene, its accelerator (the scene's own, or
/// a view of it whose traversal inlines), its triangles' normals, whether
/// it has point lights the path tracer uses, and whether the CPU draws
/// random numbers in AVX-512 lanes.
struct Lanes<'a, A> {
    scene: &'a Scene,
    accel: &'a A,
    normals: &'a [Vec3],
    point_lights: bool,
    /// Whether the vertices' random numbers are drawn 16 lanes at a time
    /// ([`avx512::vertex_numbers`]).
    avx512: bool,
}

impl<A: Accel> Lanes<'_, A> {
    /// [`Scene::intersect`] for the scenes [`supported`] admits: no
    /// unbounded primitives, triangles without interpolated normals, so
    /// the hit's normals are the stored outward one turned to the ray.
    #[inline(always)]
    fn intersect<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        let s = self.scene;
        let pr = PreparedRay::new(*ray);
        let (id, h) = self
            .accel
            .intersect(&s.prims, &pr, s.settings.max_distance, stats)?;
        let n = self.normals[id as usize];
        Some(Hit::oriented(
            ray,
            h.t,
            n,
            n,
            id,
            s.prims[id as usize].object,
        ))
    }

    /// [`Scene::occluded`] for the same scenes.
    #[inline(always)]
    fn occluded<S: Stats>(&self, ray: &Ray, t_max: f32, stats: &mut S) -> bool {
        let s = self.scene;
        self.accel
            .occluded(&s.prims, &PreparedRay::new(*ray), t_max, stats)
    }
}

/// One image row: its samples in the scalar loop's order, [`LANES`] at a
/// time, each added to its pixel in that order.
fn render_row<S: Stats, A: Accel>(
    lanes: &Lanes<A>,
    tracer: &PathTracer,
    py: u32,
    row: &mut [PixelStats],
    stats: &mut S,
) {
    let scene = lanes.scene;
    let spp = scene.settings.sampler.spp();
    let seed = scene.settings.seed;
    let total = row.len() as u64 * u64::from(spp);
    let mut next = 0u64;
    while next < total {
        let n = (total - next).min(LANES as u64) as usize;
        let ctx: [SampleContext; LANES] = std::array::from_fn(|i| {
            let k = next + (i.min(n - 1)) as u64;
            SampleContext {
                px: (k / u64::from(spp)) as u32,
                py,
                index: (k % u64::from(spp)) as u32,
                seed,
            }
        });
        let group = Group {
            lanes,
            tracer,
            ctx,
            n,
        };
        let values = trace_group(&group, stats);
        for (c, v) in ctx.iter().zip(values).take(n) {
            row[c.px as usize].add(v);
        }
        next += n as u64;
    }
}

/// The group's paths, one entry per lane: the current vertex and what the
/// path carries.
struct Paths {
    alive: [bool; LANES],
    hit: [Hit; LANES],
    /// The current vertex's albedo.
    albedo: V,
    beta: V,
    /// The light gathered after the camera hit (the scalar loop's `walk`).
    walk: V,
    /// Emission seen by the camera ray.
    emitted: V,
    /// Each lane's value once its path has ended.
    value: [Color; LANES],
}

#[inline(always)]
fn get(v: &V, i: usize) -> V3<f32> {
    V3::new(v[0][i], v[1][i], v[2][i])
}

#[inline(always)]
fn set(v: &mut V, i: usize, x: V3<f32>) {
    v[0][i] = x.x;
    v[1][i] = x.y;
    v[2][i] = x.z;
}

/// Adds `x` to lane `i` of `v`.
#[inline(always)]
fn add(v: &mut V, i: usize, x: V3<f32>) {
    set(v, i, get(v, i) + x);
}

#[inline(always)]
fn splat(c: Color) -> V {
    [[c.x; LANES], [c.y; LANES], [c.z; LANES]]
}

impl Paths {
    /// End lane `i`'s path: its value is the camera hit's emission plus
    /// what the path gathered (the scalar `emitted + walk(…)`).
    #[inline(always)]
    fn end(&mut self, i: usize) {
        self.alive[i] = false;
        self.value[i] = (get(&self.emitted, i) + get(&self.walk, i)).into();
    }
}

/// One group of samples to trace: the first `n` of `ctx` (the others
/// repeat the last one and are not traced).
struct Group<'a, A> {
    lanes: &'a Lanes<'a, A>,
    tracer: &'a PathTracer,
    ctx: [SampleContext; LANES],
    n: usize,
}

/// The values of the group's samples.
fn trace_group<S: Stats, A: Accel>(group: &Group<A>, stats: &mut S) -> [Color; LANES] {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = crate::math::Avx2::detect() {
        // SAFETY: `trace_group_avx2` is compiled for AVX2, which `avx2`, a
        // token only `Avx2::detect` makes, proves this CPU has.
        return unsafe { trace_group_avx2(avx2, group, stats) };
    }
    trace_group_in(group, stats)
}

/// [`trace_group_in`] compiled with AVX2, so the lane loops use its
/// 8-wide registers. Safe to call from code compiled for AVX2; from other
/// code, only with the CPU's AVX2 proven (`_avx2`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn trace_group_avx2<S: Stats, A: Accel>(
    _avx2: crate::math::Avx2,
    group: &Group<A>,
    stats: &mut S,
) -> [Color; LANES] {
    trace_group_in(group, stats)
}

#[inline(always)]
fn trace_group_in<S: Stats, A: Accel>(group: &Group<A>, stats: &mut S) -> [Color; LANES] {
    let Group {
        lanes,
        tracer,
        ref ctx,
        n,
    } = *group;
    let scene = lanes.scene;
    let background = scene.settings.background;
    let mut paths = Paths {
        alive: [false; LANES],
        hit: [Hit::at_surface(Vec3::ZERO, Vec3::Z); LANES],
        albedo: splat(Color::ZERO),
        beta: splat(Color::ONE),
        walk: splat(Color::ZERO),
        emitted: splat(Color::ZERO),
        value: [background; LANES],
    };
    // Camera rays (`SampleContext::camera_ray`, then `PathTracer::trace`'s
    // first hit).
    for (i, c) in ctx.iter().enumerate().take(n) {
        let (_, ray) = c.camera_ray(scene);
        stats.ray(RayKind::Camera);
        if let Some(hit) = lanes.intersect(&ray, stats) {
            set(&mut paths.emitted, i, scene.material(&hit).emission.into());
            paths.hit[i] = hit;
            paths.alive[i] = true;
        }
    }
    for bounce in 0..=tracer.max_bounces {
        if !paths.alive.contains(&true) {
            break;
        }
        vertex(lanes, tracer, ctx, bounce, &mut paths, stats);
    }
    paths.value
}

/// Lane `i`'s numbers of `u` (one array per dimension).
#[inline(always)]
fn numbers(u: &[F; DIMS_PER_VERTEX], i: usize) -> VertexNumbers {
    VertexNumbers::from(std::array::from_fn(|d| u[d][i]))
}

/// Vertex `bounce` of every live path: [`super::vertex`]'s steps in its
/// order (the scalar loop's `walk` body and `follow`), each called per
/// lane.
#[inline(always)]
fn vertex<S: Stats, A: Accel>(
    lanes: &Lanes<A>,
    tracer: &PathTracer,
    ctx: &[SampleContext; LANES],
    bounce: u32,
    paths: &mut Paths,
    stats: &mut S,
) {
    let scene = lanes.scene;
    let mut u = [[0.0f32; LANES]; DIMS_PER_VERTEX];
    #[cfg(target_arch = "x86_64")]
    if lanes.avx512 {
        // SAFETY: `vertex_numbers` needs AVX-512 F and DQ; `avx512` is set
        // only by `render_with`, from `avx512::available()`, which detects
        // both.
        u = unsafe { avx512::vertex_numbers(ctx, bounce) };
    }
    for i in 0..LANES {
        if !paths.alive[i] {
            continue;
        }
        let hit = HitR::from(paths.hit[i]);
        let bsdf = Bsdf::of(scene, &hit);
        if !bsdf.reflects() {
            paths.end(i);
            continue;
        }
        set(&mut paths.albedo, i, bsdf.albedo);
        if lanes.point_lights {
            // One shadow ray per light, as the scalar loop casts them.
            let light = bsdf.reflected(get(&paths.beta, i), point_lights(scene, &hit, stats));
            add(&mut paths.walk, i, light);
        }
        if !lanes.avx512 {
            let numbers = vertex_numbers(&ctx[i], bounce);
            for (d, x) in numbers.into_iter().enumerate() {
                u[d][i] = x;
            }
        }
    }
    let g = Geometry::of(&paths.hit);
    if tracer.samples_area_lights() {
        light_sample(lanes, tracer, &g, &u, paths, stats);
    }
    // The BSDF sample, the throughput update and the ray's origin over the
    // lanes (the ended paths' lanes too, whose numbers are defined and
    // whose results are not used: the loop has no branch to stop it
    // becoming SIMD instructions).
    let mut wi: V = [[0.0; LANES]; 3];
    let mut origin: V = [[0.0; LANES]; 3];
    let mut below = [false; LANES];
    let mut pdf: F = [0.0; LANES];
    for i in 0..LANES {
        let bsdf = Bsdf {
            albedo: get(&paths.albedo, i),
        };
        let geometric = get(&g.geometric, i).into();
        let s = bsdf.sample(get(&g.shading, i), geometric, numbers(&u, i).bsdf);
        below[i] = s.below;
        pdf[i] = s.pdf;
        let beta = s.throughput(get(&paths.beta, i));
        set(&mut paths.beta, i, beta);
        set(&mut origin, i, g.spawn_origin(i, s.wi));
        set(&mut wi, i, s.wi);
    }
    for i in 0..LANES {
        if !paths.alive[i] {
            continue;
        }
        if below[i] {
            // The path ends there, before β is multiplied, which no longer
            // matters.
            paths.end(i);
            continue;
        }
        let dir = get(&wi, i);
        let ray = Ray::new(get(&origin, i).into(), dir.into());
        stats.ray(RayKind::Path);
        let beta = get(&paths.beta, i);
        let next = lanes.intersect(&ray, stats).map(HitR::from);
        if let Some(light) = tracer.bsdf_ray_light(scene, next.as_ref(), dir, pdf[i], beta) {
            add(&mut paths.walk, i, light);
        }
        let Some(next) = next else {
            paths.end(i);
            continue;
        };
        match tracer.carry_on(bounce, beta, numbers(&u, i).roulette) {
            Some(beta) => {
                set(&mut paths.beta, i, beta);
                paths.hit[i] = next.hit;
            }
            None => paths.end(i),
        }
    }
}

/// The current vertices' point and normals over the lanes.
struct Geometry {
    point: V,
    geometric: V,
    shading: V,
}

impl Geometry {
    #[inline(always)]
    fn of(hits: &[Hit; LANES]) -> Self {
        let mut g = Geometry {
            point: [[0.0; LANES]; 3],
            geometric: [[0.0; LANES]; 3],
            shading: [[0.0; LANES]; 3],
        };
        for (i, h) in hits.iter().enumerate() {
            set(&mut g.point, i, h.point.into());
            set(&mut g.geometric, i, h.geometric_normal.into());
            set(&mut g.shading, i, h.shading_normal.into());
        }
        g
    }

    /// [`HitR::spawn_origin`] for lane `i`.
    #[inline(always)]
    fn spawn_origin(&self, i: usize, dir: V3<f32>) -> V3<f32> {
        offset_origin(get(&self.point, i), get(&self.geometric, i), dir)
    }
}

/// One area-light sample per live path (the scalar loop's
/// [`PathTracer::area_light`] over the lanes): the emitter point per lane,
/// the geometry and weights over the lanes, the shadow ray per lane.
#[inline(always)]
fn light_sample<S: Stats, A: Accel>(
    lanes: &Lanes<A>,
    tracer: &PathTracer,
    g: &Geometry,
    u: &[F; DIMS_PER_VERTEX],
    paths: &mut Paths,
    stats: &mut S,
) {
    let scene = lanes.scene;
    let mut sp: V = [[0.0; LANES]; 3];
    let mut sn: V = [[0.0; LANES]; 3];
    let mut se: V = [[0.0; LANES]; 3];
    let mut pdf_area: F = [0.0; LANES];
    let mut sampled = [false; LANES];
    for i in 0..LANES {
        if !paths.alive[i] {
            continue;
        }
        if let Some(s) = pick_area_light(scene, &numbers(u, i)) {
            set(&mut sp, i, s.point.into());
            set(&mut sn, i, s.normal.into());
            set(&mut se, i, s.emission.into());
            pdf_area[i] = s.pdf_area;
            sampled[i] = true;
        }
    }
    let mis = tracer.mis();
    let mut lit = [false; LANES];
    let mut value: V = [[0.0; LANES]; 3];
    let mut shadow_origin: V = [[0.0; LANES]; 3];
    let mut shadow_dir: V = [[0.0; LANES]; 3];
    let mut shadow_len: F = [0.0; LANES];
    for i in 0..LANES {
        let s = AreaSampleR {
            point: get(&sp, i),
            normal: get(&sn, i),
            emission: get(&se, i),
            pdf_area: pdf_area[i],
        };
        let geometric = get(&g.geometric, i).into();
        let t = lambert_area_terms(get(&g.point, i), get(&g.shading, i), geometric, &s, mis);
        lit[i] = sampled[i] && t.lit;
        set(&mut value, i, t.value);
        // The shadow segment (`Hit::shadow_segment`).
        let origin = g.spawn_origin(i, t.wi);
        let (shadow, len) = segment_to(origin.into(), get(&sp, i).into());
        set(&mut shadow_origin, i, shadow.origin.into());
        set(&mut shadow_dir, i, shadow.dir.into());
        shadow_len[i] = len;
    }
    for i in 0..LANES {
        if !(paths.alive[i] && lit[i]) {
            continue;
        }
        let shadow = Ray::new(get(&shadow_origin, i).into(), get(&shadow_dir, i).into());
        stats.ray(RayKind::Shadow);
        if lanes.occluded(&shadow, shadow_len[i], stats) {
            continue;
        }
        let bsdf = Bsdf {
            albedo: get(&paths.albedo, i),
        };
        let light = bsdf.reflected(get(&paths.beta, i), get(&value, i));
        add(&mut paths.walk, i, light);
    }
}

/// The vertices' random numbers for all [`LANES`] lanes at once, in
/// AVX-512 registers of 8 64-bit words: [`vertex_numbers`] lane by lane,
/// through the same generic formulas ([`SplitMix64::keyed`],
/// [`SplitMix64::output_words`]), so the same numbers bit for bit (the
/// 24-bit integers convert exactly, and 2⁻²⁴ scales exactly). AVX2 has no
/// 64-bit multiply, which is why this path wants AVX-512 DQ; elsewhere the
/// lanes call [`vertex_numbers`] one at a time.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::{vertex_key, SampleContext, F, LANES};
    use crate::integrator::vertex::DIMS_PER_VERTEX;
    use crate::math::{SplitMix64, Words};
    use std::arch::x86_64::*;

    /// Whether this CPU has what [`vertex_numbers`] uses.
    pub(super) fn available() -> bool {
        is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512dq")
    }

    /// 8 words, one per lane. The invariant that makes its operations'
    /// `unsafe` blocks sound: an `X8` is made and used only inside
    /// [`vertex_numbers`] (the type is private to this module, and nothing
    /// else here names it), whose contract is a CPU with AVX-512 F and DQ,
    /// which every intrinsic below needs at most.
    #[derive(Clone, Copy)]
    struct X8(__m512i);

    impl Words for X8 {
        #[inline(always)]
        fn splat(x: u64) -> Self {
            // SAFETY: AVX-512 F, present by the type's invariant.
            X8(unsafe { _mm512_set1_epi64(x as i64) })
        }
        #[inline(always)]
        fn wrapping_add(self, o: Self) -> Self {
            // SAFETY: AVX-512 F, present by the type's invariant.
            X8(unsafe { _mm512_add_epi64(self.0, o.0) })
        }
        #[inline(always)]
        fn wrapping_mul(self, o: Self) -> Self {
            // SAFETY: AVX-512 DQ, present by the type's invariant.
            X8(unsafe { _mm512_mullo_epi64(self.0, o.0) })
        }
        #[inline(always)]
        fn xor(self, o: Self) -> Self {
            // SAFETY: AVX-512 F, present by the type's invariant.
            X8(unsafe { _mm512_xor_si512(self.0, o.0) })
        }
        #[inline(always)]
        fn shr<const N: u32>(self) -> Self {
            // SAFETY: SSE2, part of x86-64.
            let count = unsafe { _mm_cvtsi32_si128(N as i32) };
            // SAFETY: AVX-512 F, present by the type's invariant.
            X8(unsafe { _mm512_srl_epi64(self.0, count) })
        }
    }

    /// [`super::vertex_numbers`] of every lane of `ctx`, by dimension.
    ///
    /// # Safety
    /// The CPU must have AVX-512 F and DQ ([`available`]).
    #[target_feature(enable = "avx512f,avx512dq")]
    pub(super) unsafe fn vertex_numbers(
        ctx: &[SampleContext; LANES],
        bounce: u32,
    ) -> [F; DIMS_PER_VERTEX] {
        let mut out = [[0.0f32; LANES]; DIMS_PER_VERTEX];
        for half in 0..LANES / 8 {
            let mut words = [[0u64; 8]; 3];
            for i in 0..8 {
                let (seed, pixel, key) = vertex_key(&ctx[half * 8 + i], bounce);
                (words[0][i], words[1][i], words[2][i]) = (seed, pixel, key);
            }
            // SAFETY: `w` is 8 readable `u64`s (64 bytes), which `loadu`
            // reads without an alignment requirement; AVX-512 F by this
            // function's contract.
            let load = |w: &[u64; 8]| X8(unsafe { _mm512_loadu_si512(w.as_ptr().cast()) });
            let state = SplitMix64::keyed(load(&words[0]), load(&words[1]), load(&words[2]));
            for (d, row) in out.iter_mut().enumerate() {
                let bits =
                    SplitMix64::output_words(state, d as u64).shr::<{ SplitMix64::UNIT_SHIFT }>();
                let unit = _mm256_mul_ps(
                    _mm512_cvtepu64_ps(bits.0),
                    _mm256_set1_ps(SplitMix64::UNIT_SCALE),
                );
                // SAFETY: `row[half * 8..]` is 8 writable `f32`s (32 bytes: a
                // row has LANES = 16, half ≤ 1), which `storeu` writes
                // without an alignment requirement.
                unsafe { _mm256_storeu_ps(row[half * 8..].as_mut_ptr(), unit) };
            }
        }
        out
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        /// The lanes' numbers are [`super::super::vertex_numbers`]' bit for
        /// bit, on contexts of every field's extremes and at random.
        #[test]
        fn lanes_draw_the_one_sample_numbers() {
            if !available() {
                return;
            }
            let mut rng = SplitMix64(3);
            for round in 0..200u64 {
                let ctx: [SampleContext; LANES] = std::array::from_fn(|i| {
                    let r = rng.next_u64();
                    let edge = round % 2 == 0 && i % 3 == 0;
                    SampleContext {
                        px: if edge { u32::MAX } else { r as u32 % 4096 },
                        py: (r >> 32) as u32 % 4096,
                        index: if edge { u32::MAX } else { (r >> 16) as u32 },
                        seed: if edge { u64::MAX } else { rng.next_u64() },
                    }
                });
                let bounce = (round % 9) as u32;
                // SAFETY: `available()` detected AVX-512 F and DQ (the test
                // returned otherwise), which is `vertex_numbers`' contract.
                let lanes = unsafe { vertex_numbers(&ctx, bounce) };
                for (i, c) in ctx.iter().enumerate() {
                    let one = super::super::vertex_numbers(c, bounce);
                    for d in 0..DIMS_PER_VERTEX {
                        assert_eq!(lanes[d][i].to_bits(), one[d].to_bits(), "lane {i} dim {d}");
                    }
                }
            }
        }
    }
}
