// raylab's Whitted integrator as a WGSL compute shader (the `gpu` feature).
//
// The shader is four files, joined in this order by crates/gpu/src/lib.rs:
// common.wgsl (constants, parameters, buffers, counters), sampling.wgsl
// (random numbers, samplers, camera rays), intersect.wgsl (primitive tests,
// bounding volumes, traversal) and whitted.wgsl (hits, shading, the
// integrator, the entry point). They are the only second copy of raylab's
// formulas the architecture allows (ARCHITECTURE.md, "A formula lives
// once"): every function names the Rust function it mirrors, in the same
// order of operations, and crates/gpu/tests/gpu.rs holds the images and the counters
// to the CPU's.
//
// The host (crates/gpu/src/lib.rs) substitutes the constants in `{{…}}` before
// compiling: the accelerator and volume kinds (so each pipeline has only
// its own traversal), the depth limit (which sizes the stacks), and whether
// counters are kept.
//
// The scene is one read-only buffer of 32-bit words (`scene`), with the
// sections at word offsets given in `P` (see crates/gpu/src/upload.rs for the
// layout of each record); floats are read with bitcast. One buffer rather
// than a dozen keeps within every adapter's storage-buffer count.

const ACCEL: u32 = {{ACCEL}}u;        // 0 brute force, 1 binary BVH, 2 4-wide BVH
const VOLUME: u32 = {{VOLUME}}u;      // binary BVH: 0 box, 1 sphere, 2 ellipsoid
const DEPTH_LIMIT: u32 = {{DEPTH_LIMIT}}u; // the scene's max_depth
const MAX_DEPTH: u32 = {{MAX_DEPTH}}u;     // max(max_depth, 1): sizes the stacks below
const STATS: bool = {{STATS}};
const MEDIA: u32 = {{MEDIA}}u;        // min(MAX_DEPTH, 16): MediumStack::CAPACITY
const TRAVERSAL_STACK: u32 = {{TRAVERSAL_STACK}}u; // bvh::MAX_DEPTH, ×3 for the 4-wide tree

struct Params {
    eye: vec3<f32>, near: f32,
    cu: vec3<f32>, half_width: f32,
    cv: vec3<f32>, half_height: f32,
    cn: vec3<f32>, max_distance: f32,
    background: vec3<f32>, min_weight: f32,
    ambient: vec3<f32>, inf: f32,
    root_min: vec3<f32>, has_root: u32,
    root_max: vec3<f32>, root_first: u32,
    width: u32, height: u32, spp: u32, sampler: u32,
    sampler_k: u32, seed_lo: u32, seed_hi: u32, row_offset: u32,
    root_count: u32, n_accel: u32, n_unbounded: u32, n_lights: u32,
    o_nodes: u32, o_refs: u32, o_ids: u32, o_tris: u32,
    o_spheres: u32, o_ellipsoids: u32, o_planes: u32, o_prim_object: u32,
    o_meshes: u32, o_faces: u32, o_normals: u32, o_materials: u32,
    o_lights: u32, o_halton: u32, slab_exit_scale: f32, offset_scale: f32,
    quadric_margin: f32, rows: u32, sample_first: u32, sample_count: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> scene: array<u32>;
// Per pixel: mean (3), count, m2 (3), and 1 where the loop guard tripped.
@group(0) @binding(2) var<storage, read_write> pixels: array<f32>;
// Per pixel: the 15 counters of stats::Counters, in its field order, and
// the primitive first hit by the pixel's first camera ray (+1; 0: none).
@group(0) @binding(3) var<storage, read_write> counts: array<u32>;

fn f(i: u32) -> f32 { return bitcast<f32>(scene[i]); }
fn v3(i: u32) -> vec3<f32> { return vec3<f32>(f(i), f(i + 1u), f(i + 2u)); }

// ---------------------------------------------------------------- counters
// Indices into stats::Counters' fields.
const C_CAMERA: u32 = 0u; const C_SHADOW: u32 = 1u; const C_REFLECTION: u32 = 2u;
const C_REFRACTION: u32 = 3u; const C_NODES: u32 = 6u; const C_BOX: u32 = 7u;
const C_BSPHERE: u32 = 8u; const C_BELLIPSOID: u32 = 9u; const C_TRIANGLE: u32 = 10u;
const C_SPHERE: u32 = 11u; const C_ELLIPSOID: u32 = 12u; const C_PLANE: u32 = 13u;
const C_PRIM_HIT: u32 = 14u;
const N_COUNTERS: u32 = 15u;
const COUNT_WORDS: u32 = 16u;

var<private> counters: array<u32, 15>;
fn count(c: u32) { if STATS { counters[c] += 1u; } }
fn count_n(c: u32, n: u32) { if STATS { counters[c] += n; } }

// ------------------------------------------------------------ loop guard
// Mesa's lavapipe (llvmpipe) ends an invocation's loops once they have
// iterated 65535 times in all (its guard against endless shaders), and
// the shader then goes on with wrong results. Every loop here ticks this
// counter once per iteration (LOOP_GUARD is on for lavapipe), and a pixel
// whose invocation came near the limit is flagged in the film buffer: the
// host refuses the render rather than return such an image. The host runs
// one sample per dispatch, which keeps trees far below the limit; brute
// force (one iteration per primitive and ray) reaches it at a few ten
// thousand primitives.
const LOOP_GUARD: bool = {{LOOP_GUARD}};
const GUARD_LIMIT: u32 = 65000u;
var<private> guard: u32;
fn tick() { if LOOP_GUARD { guard += 1u; } }

