// raylab's Whitted integrator as a WGSL compute shader (the `gpu` feature).
//
// This file is the only second copy of raylab's formulas the architecture
// allows (ARCHITECTURE.md, "A formula lives once"): every function below
// names the Rust function it mirrors, in the same order of operations, and
// tests/gpu.rs holds the images and the counters to the CPU's.
//
// The host (src/gpu/mod.rs) substitutes the constants in `{{…}}` before
// compiling: the accelerator and volume kinds (so each pipeline has only
// its own traversal), the depth limit (which sizes the stacks), and whether
// counters are kept.
//
// The scene is one read-only buffer of 32-bit words (`scene`), with the
// sections at word offsets given in `P` (see src/gpu/upload.rs for the
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

// ------------------------------------------------ SplitMix64 (math::rng)
// u64 as (low, high) words.
fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}
fn shr64(a: vec2<u32>, s: u32) -> vec2<u32> { // 0 < s < 32
    return vec2<u32>((a.x >> s) | (a.y << (32u - s)), a.y >> s);
}
fn mul32(a: u32, b: u32) -> vec2<u32> { // the full 64-bit product
    let a0 = a & 0xffffu; let a1 = a >> 16u; let b0 = b & 0xffffu; let b1 = b >> 16u;
    let p00 = a0 * b0; let p01 = a0 * b1; let p10 = a1 * b0; let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}
fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> { // wrapping
    let p = mul32(a.x, b.x);
    return vec2<u32>(p.x, p.y + a.x * b.y + a.y * b.x);
}
const GAMMA = vec2<u32>(0x7F4A7C15u, 0x9E3779B9u);
// SplitMix64::mix
fn mix64(z0: vec2<u32>) -> vec2<u32> {
    var z = add64(z0, GAMMA);
    z = mul64(z ^ shr64(z, 30u), vec2<u32>(0x1CE4E5B9u, 0xBF58476Du));
    z = mul64(z ^ shr64(z, 27u), vec2<u32>(0x133111EBu, 0x94D049BBu));
    return z ^ shr64(z, 31u);
}
var<private> rng: vec2<u32>;
fn next_u64() -> vec2<u32> { let out = mix64(rng); rng = add64(rng, GAMMA); return out; }
fn next_f32() -> f32 { return f32(next_u64().y >> 8u) * (1.0 / 16777216.0); }
// sampler::stream
fn stream(px: u32, py: u32, key: vec2<u32>) {
    let seed = vec2<u32>(P.seed_lo, P.seed_hi);
    rng = mix64(seed ^ mix64(vec2<u32>(px, py) ^ mix64(key)));
}

// ------------------------------------------------------- sampler::sample
const PIXEL_KEY = vec2<u32>(0xffffffffu, 0xffffffffu);
fn wrap(x: f32) -> f32 { let w = x - floor(x); return select(w, 0.0, w >= 1.0); }
fn fraction(bits: u32) -> f32 { return f32(bits >> 8u) * (1.0 / 16777216.0); }
fn sobol_second(i0: u32) -> u32 {
    var i = i0; var r = 0u; var v = 1u << 31u;
    while i != 0u {
        tick();
        if (i & 1u) != 0u { r ^= v; }
        i >>= 1u; v ^= v >> 1u;
    }
    return r;
}
fn sample_offset(px: u32, py: u32, index: u32) -> vec2<f32> {
    let k = P.sampler_k;
    switch P.sampler {
        case 0u: { return vec2<f32>(0.5); } // centre
        case 1u: { // ordered grid
            return (vec2<f32>(f32(index % k), f32(index / k)) + 0.5) / f32(k);
        }
        case 2u: { // rotated grid: RGSS
            var cells = array<vec2<u32>, 4>(vec2<u32>(1u, 0u), vec2<u32>(3u, 1u), vec2<u32>(2u, 3u), vec2<u32>(0u, 2u));
            let c = cells[index % 4u];
            return (vec2<f32>(f32(c.x), f32(c.y)) + 0.5) / 4.0;
        }
        case 3u: { // jittered
            stream(px, py, vec2<u32>(index, 0u));
            let u = next_f32();
            let v = next_f32();
            return (vec2<f32>(f32(index % k), f32(index / k)) + vec2<f32>(u, v)) / f32(k);
        }
        case 4u: { // random
            stream(px, py, vec2<u32>(index, 0u));
            let u = next_f32();
            return vec2<f32>(u, next_f32());
        }
        case 5u: { // halton: radical inverses from the host's table
            stream(px, py, PIXEL_KEY);
            let sx = next_f32();
            let sy = next_f32();
            let h = P.o_halton + 2u * index;
            return vec2<f32>(wrap(f(h) + sx), wrap(f(h + 1u) + sy));
        }
        default: { // sobol
            stream(px, py, PIXEL_KEY);
            let sx = next_u64().x;
            let sy = next_u64().x;
            return vec2<f32>(fraction(reverseBits(index) ^ sx), fraction(sobol_second(index) ^ sy));
        }
    }
}

// ---------------------------------------------------------------- vectors
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 { return a.x * b.x + a.y * b.y + a.z * b.z; }
fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}
fn length3(a: vec3<f32>) -> f32 { return sqrt(dot3(a, a)); }
// V3::normalize / glam: v · (1/|v|)
fn normalize3(a: vec3<f32>) -> vec3<f32> { return a * (1.0 / length3(a)); }
fn finite(x: f32) -> bool { return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u; }
fn is_nan(x: f32) -> bool { return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u; }
// glam's normalize_or_zero
fn normalize_or_zero(a: vec3<f32>) -> vec3<f32> {
    let rcp = 1.0 / length3(a);
    if finite(rcp) && rcp > 0.0 { return a * rcp; }
    return vec3<f32>(0.0);
}
fn max_abs(p: vec3<f32>) -> f32 { let a = abs(p); return max(max(a.x, a.y), a.z); }

// ------------------------------------------------------------------- rays
struct Ray { o: vec3<f32>, d: vec3<f32>, inv: vec3<f32>, kx: u32, ky: u32, kz: u32, shear: vec3<f32> }

fn recip(x: f32) -> f32 {
    if x == 0.0 { return select(P.inf, -P.inf, (bitcast<u32>(x) >> 31u) != 0u); }
    return 1.0 / x;
}
// shape::PreparedRay::new
fn prepare(o: vec3<f32>, d: vec3<f32>) -> Ray {
    let a = abs(d);
    var kz = 2u;
    if a.x >= a.y && a.x >= a.z { kz = 0u; } else if a.y >= a.z { kz = 1u; }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if d[kz] < 0.0 { let t = kx; kx = ky; ky = t; }
    let shear = vec3<f32>(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    return Ray(o, d, vec3<f32>(recip(d.x), recip(d.y), recip(d.z)), kx, ky, kz, shear);
}

// camera::Frame::ray
fn camera_ray(x: f32, y: f32) -> Ray {
    let w = P.half_width; let h = P.half_height;
    let uc = -w + 2.0 * w * x / f32(P.width);
    let r = f32(P.height) - y;
    let vr = -h + 2.0 * h * r / f32(P.height);
    let dir = P.cn * -P.near + P.cu * uc + P.cv * vr;
    return prepare(P.eye, normalize3(dir));
}

// ------------------------------------------------------- primitive tests
struct PrimHit { t: f32, u: f32, v: f32 }
const MISS = PrimHit(-1.0, 0.0, 0.0);

// f32::signum: ±1 by the sign bit (signum(+0) = 1, unlike WGSL's sign)
fn signum(x: f32) -> f32 { return select(1.0, -1.0, (bitcast<u32>(x) >> 31u) != 0u); }
// Sphere::roots: the stable quadratic; (t0, t1, ok)
fn roots(o: vec3<f32>, d: vec3<f32>, centre: vec3<f32>, radius: f32) -> vec3<f32> {
    let fv = o - centre;
    let a = dot3(d, d);
    let b = -dot3(fv, d);
    let c = dot3(fv, fv) - radius * radius;
    let l = fv + (b / a) * d;
    let disc = radius * radius - dot3(l, l);
    if !(disc >= 0.0) { return vec3<f32>(0.0, 0.0, 0.0); }
    let q = b + signum(b) * sqrt(a * disc);
    if q == 0.0 { return vec3<f32>(0.0, 0.0, 1.0); }
    let t0 = c / q; let t1 = q / a;
    if t0 <= t1 { return vec3<f32>(t0, t1, 1.0); }
    return vec3<f32>(t1, t0, 1.0);
}
// sphere::nearest_root
fn nearest_root(r: vec3<f32>, t_max: f32) -> PrimHit {
    if r.z == 0.0 { return MISS; }
    let t = select(r.y, r.x, r.x > 0.0);
    if t > 0.0 && t < t_max { return PrimHit(t, 0.0, 0.0); }
    return MISS;
}
fn sphere_test(i: u32, ray: Ray, t_max: f32) -> PrimHit {
    count(C_SPHERE);
    let b = P.o_spheres + 4u * i;
    return nearest_root(roots(ray.o, ray.d, v3(b), f(b + 3u)), t_max);
}
// Mat3 * v, glam's column-major order
fn mat_mul(b: u32, v: vec3<f32>) -> vec3<f32> {
    return v3(b) * v.x + v3(b + 3u) * v.y + v3(b + 6u) * v.z;
}
fn mat_t_mul(b: u32, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot3(v3(b), v), dot3(v3(b + 3u), v), dot3(v3(b + 6u), v));
}
fn ellipsoid_test(i: u32, ray: Ray, t_max: f32) -> PrimHit {
    count(C_ELLIPSOID);
    let b = P.o_ellipsoids + 12u * i;
    let m = b + 3u;
    let lo = mat_mul(m, ray.o - v3(b));
    let ld = mat_mul(m, ray.d);
    return nearest_root(roots(lo, ld, vec3<f32>(0.0), 1.0), t_max);
}
fn plane_test(i: u32, ray: Ray, t_max: f32) -> PrimHit {
    count(C_PLANE);
    let b = P.o_planes + 6u * i;
    let n = v3(b + 3u);
    let denom = dot3(n, ray.d);
    if denom == 0.0 { return MISS; }
    let t = dot3(n, v3(b) - ray.o) / denom;
    if t > 0.0 && t < t_max { return PrimHit(t, 0.0, 0.0); }
    return MISS;
}
// a·b − c·d as the f64 fallback of the triangle test computes it: the
// products exactly (two-product by fma), their difference rounded once.
fn diff_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let p = a * b; let pe = fma(a, b, -p);
    let q = c * d; let qe = fma(c, d, -q);
    return (p - q) + (pe - qe);
}
// Triangle::intersect: Woop, Benthin & Wald's watertight test
fn triangle_test(i: u32, ray: Ray, t_max: f32) -> PrimHit {
    count(C_TRIANGLE);
    let base = P.o_tris + 11u * i;
    let a = v3(base) - ray.o;
    let b = v3(base + 3u) - ray.o;
    let c = v3(base + 6u) - ray.o;
    let s = ray.shear;
    let ax = a[ray.kx] - s.x * a[ray.kz];
    let ay = a[ray.ky] - s.y * a[ray.kz];
    let bx = b[ray.kx] - s.x * b[ray.kz];
    let by = b[ray.ky] - s.y * b[ray.kz];
    let cx = c[ray.kx] - s.x * c[ray.kz];
    let cy = c[ray.ky] - s.y * c[ray.kz];
    var u = cx * by - cy * bx;
    var v = ax * cy - ay * cx;
    var w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = diff_of_products(cx, by, cy, bx);
        v = diff_of_products(ax, cy, ay, cx);
        w = diff_of_products(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) { return MISS; }
    let det = u + v + w;
    if det == 0.0 { return MISS; }
    let az = s.z * a[ray.kz];
    let bz = s.z * b[ray.kz];
    let cz = s.z * c[ray.kz];
    let t_scaled = u * az + v * bz + w * cz;
    if det > 0.0 {
        if t_scaled <= 0.0 || t_scaled >= t_max * det { return MISS; }
    } else if t_scaled >= 0.0 || t_scaled <= t_max * det { return MISS; }
    let inv = 1.0 / det;
    return PrimHit(t_scaled * inv, v * inv, w * inv);
}
// arrays::Slot::test: slot → kind and index (PrimRef: kind in the top two bits)
fn slot_test(slot: u32, ray: Ray, t_max: f32) -> PrimHit {
    let r = scene[P.o_refs + slot];
    let i = r & 0x3fffffffu;
    switch r >> 30u {
        case 0u: { return triangle_test(i, ray, t_max); }
        case 1u: { return sphere_test(i, ray, t_max); }
        case 2u: { return ellipsoid_test(i, ray, t_max); }
        default: { return plane_test(i, ray, t_max); }
    }
}

// --------------------------------------------------- slots: closest / any
struct Found { slot: u32, h: PrimHit }
const NONE: u32 = 0xffffffffu;
// brute::closest_of over slots [first, first + n), in order. (One slot per
// iteration: unrolling it to spare lavapipe's loop guard, see `tick`,
// made the shader eight times longer to compile.)
fn closest_of(first: u32, n: u32, ray: Ray, t_max: ptr<function, f32>, best: ptr<function, Found>) {
    for (var s = first; s < first + n; s++) {
        tick();
        let h = slot_test(s, ray, *t_max);
        if h.t >= 0.0 {
            count(C_PRIM_HIT);
            *t_max = h.t;
            *best = Found(s, h);
        }
    }
}
// brute::any_of
fn any_of(first: u32, n: u32, ray: Ray, t_max: f32) -> bool {
    for (var s = first; s < first + n; s++) {
        tick();
        if slot_test(s, ray, t_max).t >= 0.0 { count(C_PRIM_HIT); return true; }
    }
    return false;
}

// ------------------------------------------------------ bounding volumes
// Aabb::slab (and each lane of slab4): entry distance, or −1 for a miss.
fn slab(lo: vec3<f32>, hi: vec3<f32>, ray: Ray, t_max: f32) -> f32 {
    let t0 = (lo - ray.o) * ray.inv;
    let t1 = (hi - ray.o) * ray.inv;
    var enter = -P.inf;
    var exit = P.inf;
    // The three axes written out (no loop: see `tick`).
    if !(is_nan(t0.x) || is_nan(t1.x)) { enter = max(enter, min(t0.x, t1.x)); exit = min(exit, max(t0.x, t1.x)); }
    if !(is_nan(t0.y) || is_nan(t1.y)) { enter = max(enter, min(t0.y, t1.y)); exit = min(exit, max(t0.y, t1.y)); }
    if !(is_nan(t0.z) || is_nan(t1.z)) { enter = max(enter, min(t0.z, t1.z)); exit = min(exit, max(t0.z, t1.z)); }
    exit = exit * P.slab_exit_scale;
    if enter <= exit && exit >= 0.0 && enter <= t_max { return max(enter, 0.0); }
    return -1.0;
}
// volume::unit_quadric_entry
fn quadric_entry(fv: vec3<f32>, d: vec3<f32>, r: f32, t_max: f32) -> f32 {
    let padded = r + P.quadric_margin * (length3(fv) + r);
    let t = roots(fv, d, vec3<f32>(0.0), padded);
    if t.z != 0.0 && t.y >= 0.0 && t.x <= t_max { return max(t.x, 0.0); }
    return -1.0;
}
// BoundingVolume::hit of binary node `n` (12 words: volume (8), first, count)
fn volume_hit(n: u32, ray: Ray, t_max: f32) -> f32 {
    let b = P.o_nodes + 12u * n;
    switch VOLUME {
        case 0u: { count(C_BOX); return slab(v3(b), v3(b + 4u), ray, t_max); }
        case 1u: {
            count(C_BSPHERE);
            return quadric_entry(ray.o - v3(b), ray.d, f(b + 3u), t_max);
        }
        default: {
            count(C_BELLIPSOID);
            let inv_r = v3(b + 4u);
            return quadric_entry((ray.o - v3(b)) * inv_r, ray.d * inv_r, 1.0, t_max);
        }
    }
}

// --------------------------------------------------------------- traversal
// One loop for closest hit and any hit, as bvh::traverse (binary) and
// wide::Bvh4::traverse: the same order of visits, so the same counts.
var<private> stack_node: array<u32, TRAVERSAL_STACK>;
var<private> stack_t: array<f32, TRAVERSAL_STACK>;
var<private> stack_count: array<u32, TRAVERSAL_STACK>; // 4-wide: a leaf's count, 0 for a node

fn traverse(ray: Ray, t_max0: f32, any_hit: bool, best: ptr<function, Found>) -> bool {
    var t_max = t_max0;
    if ACCEL == 0u {
        if any_hit { return any_of(0u, P.n_accel, ray, t_max); }
        closest_of(0u, P.n_accel, ray, &t_max, best);
        return (*best).slot != NONE;
    }
    if P.has_root == 0u { return false; }
    var depth = 0u;
    var node = 0u;   // binary: node index; 4-wide: wide node or leaf (first)
    var leaf = 0u;   // 4-wide: leaf primitive count (0: a wide node)
    if ACCEL == 1u {
        if volume_hit(0u, ray, t_max) < 0.0 { return false; }
    } else {
        count(C_BOX);
        if slab(P.root_min, P.root_max, ray, t_max) < 0.0 { return false; }
        node = P.root_first;
        leaf = P.root_count;
    }
    loop {
        tick();
        count(C_NODES);
        var descend = false;
        if ACCEL == 1u {
            let b = P.o_nodes + 12u * node;
            let first = scene[b + 8u];
            let n = scene[b + 9u];
            if n > 0u {
                if any_hit {
                    if any_of(first, n, ray, t_max) { return true; }
                } else {
                    closest_of(first, n, ray, &t_max, best);
                }
            } else {
                let tl = volume_hit(first, ray, t_max);
                let tr = volume_hit(first + 1u, ray, t_max);
                if tl >= 0.0 && tr >= 0.0 {
                    var near = first; var far = first + 1u; var t_far = tr;
                    if !(tl <= tr) { near = first + 1u; far = first; t_far = tl; }
                    stack_node[depth] = far; stack_t[depth] = t_far; depth++;
                    node = near; descend = true;
                } else if tl >= 0.0 { node = first; descend = true; }
                else if tr >= 0.0 { node = first + 1u; descend = true; }
            }
        } else {
            if leaf > 0u {
                if any_hit {
                    if any_of(node, leaf, ray, t_max) { return true; }
                } else {
                    closest_of(node, leaf, ray, &t_max, best);
                }
            } else {
                // Node4: min x,y,z (4 lanes each), max x,y,z, first[4], count[4];
                // unused lanes have first = count = NONE.
                let b = P.o_nodes + 32u * node;
                var hn = array<u32, 4>(0u, 0u, 0u, 0u);
                var hc = array<u32, 4>(0u, 0u, 0u, 0u);
                var ht = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
                var k = 0u;
                for (var i = 0u; i < 4u; i++) {
                    tick();
                    if scene[b + 28u + i] == NONE { break; }
                    count(C_BOX);
                    let lo = vec3<f32>(f(b + i), f(b + 4u + i), f(b + 8u + i));
                    let hi = vec3<f32>(f(b + 12u + i), f(b + 16u + i), f(b + 20u + i));
                    let t = slab(lo, hi, ray, t_max);
                    if t >= 0.0 {
                        // insertion, nearest first; ties keep child order
                        var j = k;
                        while j > 0u && ht[j - 1u] > t {
                            tick();
                            hn[j] = hn[j - 1u]; hc[j] = hc[j - 1u]; ht[j] = ht[j - 1u];
                            j--;
                        }
                        hn[j] = scene[b + 24u + i]; hc[j] = scene[b + 28u + i]; ht[j] = t;
                        k++;
                    }
                }
                if k > 0u {
                    for (var j = k - 1u; j >= 1u; j--) {
                        tick();
                        stack_node[depth] = hn[j]; stack_t[depth] = ht[j]; stack_count[depth] = hc[j];
                        depth++;
                    }
                    node = hn[0]; leaf = hc[0]; descend = true;
                }
            }
        }
        if descend { continue; }
        // bvh::traverse::pop_live
        var popped = false;
        loop {
            tick();
            if depth == 0u { break; }
            depth--;
            if stack_t[depth] <= t_max {
                node = stack_node[depth];
                if ACCEL == 2u { leaf = stack_count[depth]; }
                popped = true;
                break;
            }
        }
        if !popped { return (*best).slot != NONE; }
    }
    return false;
}

// Scene::intersect_prim: the accelerator, then the unbounded primitives.
fn intersect(ray: Ray, t_max: f32) -> Found {
    var best = Found(NONE, MISS);
    traverse(ray, t_max, false, &best);
    var t = t_max;
    if best.slot != NONE { t = best.h.t; }
    closest_of(P.n_accel, P.n_unbounded, ray, &t, &best);
    return best;
}
// Scene::occluded: the unbounded primitives, then the accelerator.
fn occluded(ray: Ray, t_max: f32) -> bool {
    if any_of(P.n_accel, P.n_unbounded, ray, t_max) { return true; }
    var none = Found(NONE, MISS);
    return traverse(ray, t_max, true, &none);
}

// ---------------------------------------------------------------- the hit
struct Hit { point: vec3<f32>, gn: vec3<f32>, sn: vec3<f32>, prim: u32, object: u32, front: bool }

// Scene::hit_details
fn hit_details(ray: Ray, found: Found) -> Hit {
    let prim = scene[P.o_ids + found.slot];
    let h = found.h;
    let point = ray.o + ray.d * h.t;
    let r = scene[P.o_refs + found.slot];
    let i = r & 0x3fffffffu;
    var outward: vec3<f32>;
    var shading: vec3<f32>;
    switch r >> 30u {
        case 0u: {
            let b = P.o_tris + 11u * i;
            let p0 = v3(b);
            outward = normalize_or_zero(cross3(v3(b + 3u) - p0, v3(b + 6u) - p0));
            shading = outward;
            let mesh = scene[b + 9u];
            if mesh != NONE {
                let m = P.o_meshes + 4u * mesh;
                if scene[m + 2u] != 0u {
                    let fc = P.o_faces + 3u * (scene[m] + scene[b + 10u]);
                    let nb = P.o_normals + 3u * scene[m + 1u];
                    let n = (1.0 - h.u - h.v) * v3(nb + 3u * scene[fc])
                        + h.u * v3(nb + 3u * scene[fc + 1u])
                        + h.v * v3(nb + 3u * scene[fc + 2u]);
                    let nn = normalize_or_zero(n);
                    if nn.x != 0.0 || nn.y != 0.0 || nn.z != 0.0 {
                        shading = select(nn, -nn, dot3(nn, outward) < 0.0);
                    }
                }
            }
        }
        case 1u: {
            let b = P.o_spheres + 4u * i;
            outward = normalize3((point - v3(b)) / f(b + 3u));
            shading = outward;
        }
        case 2u: {
            let b = P.o_ellipsoids + 12u * i;
            let local = mat_mul(b + 3u, point - v3(b));
            outward = normalize3(mat_t_mul(b + 3u, local));
            shading = outward;
        }
        default: {
            outward = v3(P.o_planes + 6u * i + 3u);
            shading = outward;
        }
    }
    let front = dot3(outward, ray.d) < 0.0;
    let sgn = select(-1.0, 1.0, front);
    return Hit(point, sgn * outward, sgn * shading, prim, scene[P.o_prim_object + prim], front);
}

// HitR::spawn_origin
fn spawn_origin(hit: Hit, dir: vec3<f32>) -> vec3<f32> {
    let eps = P.offset_scale * max(max_abs(hit.point), 1.0);
    if dot3(hit.gn, dir) >= 0.0 { return hit.point + hit.gn * eps; }
    return hit.point - hit.gn * eps;
}

// ---------------------------------------------------------------- shading
// Material record (32 words): colour (3), ambient, diffuse, specular,
// shininess, specular colour (3), reflectivity, transparency, ior,
// emission (3), texture kind (0 none, 1 checker, 2 zone plate), size or k,
// texture colour (3), origin (3), u axis (3), v axis (3), unused.
struct Material {
    color: vec3<f32>, ambient: f32, diffuse: f32, specular: f32, shininess: f32,
    specular_color: vec3<f32>, reflectivity: f32, transparency: f32, ior: f32,
    emission: vec3<f32>,
}
fn material(object: u32) -> Material {
    let b = P.o_materials + 32u * object;
    return Material(v3(b), f(b + 3u), f(b + 4u), f(b + 5u), f(b + 6u), v3(b + 7u),
        f(b + 10u), f(b + 11u), f(b + 12u), v3(b + 13u));
}
// MaterialR::color_at with Texture::value_at
fn color_at(object: u32, color: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    let b = P.o_materials + 32u * object;
    let kind = scene[b + 16u];
    if kind == 0u { return color; }
    var w: f32;
    let d = p - v3(b + 21u);
    if kind == 1u {
        let size = f(b + 17u);
        let u = dot3(d, v3(b + 24u)) / size;
        let v = dot3(d, v3(b + 27u)) / size;
        let parity = (i32(floor(u)) + i32(floor(v))) & 1;
        w = select(0.0, 1.0, parity == 0);
    } else {
        let u = dot3(d, v3(b + 24u));
        let v = dot3(d, v3(b + 27u));
        w = 0.5 * (1.0 + sin(f(b + 17u) * (u * u + v * v)));
    }
    return color * w + v3(b + 18u) * (1.0 - w);
}
// shading::reflect
fn reflect3(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> { return d + n * (2.0 * dot3(n, -d)); }
// shading::refract; w = 0 for total internal reflection
fn refract3(i: vec3<f32>, n: vec3<f32>, eta: f32) -> vec4<f32> {
    let cos_i = dot3(n, i);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if k < 0.0 { return vec4<f32>(0.0); }
    return vec4<f32>(n * (eta * cos_i - sqrt(k)) - i * eta, 1.0);
}
// f32::powf for the specular lobe's base in [0, ∞)
fn powf(x: f32, y: f32) -> f32 {
    if y == 0.0 { return 1.0; }
    if x == 0.0 { return select(P.inf, 0.0, y > 0.0); }
    return pow(x, y);
}
// shading::phong
fn phong(m: Material, albedo: vec3<f32>, n: vec3<f32>, l: vec3<f32>, view: vec3<f32>, e: vec3<f32>) -> vec3<f32> {
    let diffuse = m.diffuse * dot3(n, l);
    let r = reflect3(-l, n);
    let specular = m.specular * powf(max(dot3(r, view), 0.0), m.shininess);
    return e * (albedo * diffuse + m.specular_color * specular);
}

// lighting::point_light_incidence + shading::phong, for every light
// (LightModel::Whitted sees them all). Light record: position (3),
// inverse-square flag, radiance (3), unused.
fn lights(hit: Hit, m: Material, albedo: vec3<f32>, view: vec3<f32>) -> vec3<f32> {
    var color = vec3<f32>(0.0);
    for (var i = 0u; i < P.n_lights; i++) {
        tick();
        let b = P.o_lights + 8u * i;
        let position = v3(b);
        let to_light = position - hit.point;
        let dist = length3(to_light);
        let l = to_light / dist;
        let cos_theta = dot3(hit.sn, l);
        if cos_theta <= 0.0 || dot3(hit.gn, l) <= 0.0 { continue; }
        // Hit::shadow_segment
        let origin = spawn_origin(hit, l);
        let to_target = position - origin;
        let len = length3(to_target);
        count(C_SHADOW);
        if occluded(prepare(origin, to_target / len), len * (1.0 - P.offset_scale)) { continue; }
        var arriving = v3(b + 4u);
        if scene[b + 3u] != 0u { arriving = arriving / (dist * dist); }
        color += phong(m, albedo, hit.sn, l, view, arriving);
    }
    return color;
}

// --------------------------------------------------------- the integrator
// whitted::MediumStack and whitted::Pending, in arrays indexed by the
// pending ray's slot: media[slot * MEDIA + k] = (object, ior).
struct Pending { o: vec3<f32>, factor: f32, d: vec3<f32>, depth: u32, weight: f32, media_len: u32 }
var<private> pending: array<Pending, MAX_DEPTH>;
var<private> media_obj: array<u32, MAX_DEPTH * MEDIA>;
var<private> media_ior: array<f32, MAX_DEPTH * MEDIA>;
var<private> cur_obj: array<u32, MEDIA>;
var<private> cur_ior: array<f32, MEDIA>;
// The primitive the first camera ray of the pixel hits (+1; 0: none), and
// whether the ray being traced is that one.
var<private> first_prim: u32;
var<private> record_first: bool;

// medium_ior of the current stack with `len` entries
fn current_ior(len: u32) -> f32 {
    if len == 0u { return 1.0; }
    return material(cur_obj[len - 1u]).ior;
}

// whitted::trace and whitted::shade as one loop
fn trace(camera: Ray) -> vec3<f32> {
    var color = vec3<f32>(0.0);
    var n_pending = 1u;
    pending[0] = Pending(camera.o, 1.0, camera.d, 0u, 1.0, 0u);
    while n_pending > 0u {
        tick();
        n_pending--;
        let p = pending[n_pending];
        let factor = p.factor;
        // the popped ray's media, into cur_*
        for (var k = 0u; k < p.media_len; k++) {
            tick();
            cur_obj[k] = media_obj[n_pending * MEDIA + k];
            cur_ior[k] = media_ior[n_pending * MEDIA + k];
        }
        let ray = prepare(p.o, p.d);
        let found = intersect(ray, P.max_distance);
        if record_first {
            record_first = false;
            if found.slot != NONE { first_prim = scene[P.o_ids + found.slot] + 1u; }
        }
        if found.slot == NONE { color += P.background * factor; continue; }
        let hit = hit_details(ray, found);
        let m = material(hit.object);
        let n = hit.sn;
        let view = -ray.d;
        let albedo = color_at(hit.object, m.color, hit.point);
        var local = m.emission + P.ambient * m.ambient * albedo;
        local += lights(hit, m, albedo, view);
        color += local * factor;

        if p.depth + 1u >= DEPTH_LIMIT { continue; }
        var reflect_weight = m.reflectivity;
        var refracted = false;
        var t_dir = vec3<f32>(0.0);
        var t_len = 0u;
        if m.transparency > 0.0 && p.weight * m.transparency >= P.min_weight {
            var n1: f32; var n2: f32;
            if hit.front {
                n1 = current_ior(p.media_len);
                n2 = m.ior;
                t_len = p.media_len;
                if t_len < MEDIA {
                    cur_obj[t_len] = hit.object; cur_ior[t_len] = m.ior; t_len++;
                }
            } else {
                n1 = current_ior(p.media_len);
                // MediumStack::left: remove the innermost entry of this object
                t_len = p.media_len;
                var at = NONE;
                for (var k = 0u; k < p.media_len; k++) { tick(); if cur_obj[k] == hit.object { at = k; } }
                if at != NONE {
                    for (var k = at; k + 1u < p.media_len; k++) {
                        tick();
                        cur_obj[k] = cur_obj[k + 1u]; cur_ior[k] = cur_ior[k + 1u];
                    }
                    t_len--;
                }
                n2 = current_ior(t_len);
            }
            let t = refract3(view, n, n1 / n2);
            if t.w != 0.0 {
                t_dir = normalize3(t.xyz);
                count(C_REFRACTION);
                refracted = true;
            } else {
                reflect_weight += m.transparency;
            }
        }
        // The reflected ray keeps the popped ray's media: push it first
        // (from the saved copy in its slot, which is still intact).
        let rw = reflect_weight;
        if rw > 0.0 && p.weight * rw >= P.min_weight {
            let r_dir = normalize3(reflect3(ray.d, n));
            count(C_REFLECTION);
            // slot n_pending already holds the popped ray's media
            pending[n_pending] = Pending(spawn_origin(hit, r_dir), factor * rw, r_dir, p.depth + 1u, p.weight * rw, p.media_len);
            n_pending++;
        }
        if refracted {
            let s = n_pending;
            for (var k = 0u; k < t_len; k++) {
                tick();
                media_obj[s * MEDIA + k] = cur_obj[k];
                media_ior[s * MEDIA + k] = cur_ior[k];
            }
            pending[s] = Pending(spawn_origin(hit, t_dir), factor * m.transparency, t_dir, p.depth + 1u, p.weight * m.transparency, t_len);
            n_pending++;
        }
    }
    return color;
}

// One dispatch renders samples [sample_first, sample_first + sample_count)
// of every pixel of a band of rows, continuing each pixel's Welford sums,
// counters and first hit from the buffers: the host splits a render into
// dispatches of one sample (so that one invocation's loops stay short, see
// `tick`), and the result is the same as one loop over all samples.
@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let px = gid.x;
    let py = gid.y + P.row_offset;
    if px >= P.width || gid.y >= P.rows || py >= P.height { return; }
    let pix = py * P.width + px;
    let fresh = P.sample_first == 0u;
    guard = 0u;
    for (var c = 0u; c < N_COUNTERS; c++) {
        tick();
        counters[c] = select(counts[COUNT_WORDS * pix + c], 0u, fresh || !STATS);
    }
    first_prim = select(counts[COUNT_WORDS * pix + 15u], 0u, fresh || !STATS);
    // film::PixelStats::add (Welford), sample after sample
    var mean = vec3<f32>(0.0);
    var m2 = vec3<f32>(0.0);
    if !fresh {
        mean = vec3<f32>(pixels[8u * pix], pixels[8u * pix + 1u], pixels[8u * pix + 2u]);
        m2 = vec3<f32>(pixels[8u * pix + 4u], pixels[8u * pix + 5u], pixels[8u * pix + 6u]);
    }
    var flagged = select(pixels[8u * pix + 7u], 0.0, fresh);
    let end = P.sample_first + P.sample_count;
    for (var index = P.sample_first; index < end; index++) {
        tick();
        let off = sample_offset(px, py, index);
        let pos = vec2<f32>(f32(px), f32(py)) + off;
        let ray = camera_ray(pos.x, pos.y);
        count(C_CAMERA);
        record_first = index == 0u;
        let x = trace(ray);
        let delta = x - mean;
        mean += delta / f32(index + 1u);
        m2 += delta * (x - mean);
    }
    if LOOP_GUARD && guard >= GUARD_LIMIT { flagged = 1.0; }
    pixels[8u * pix] = mean.x; pixels[8u * pix + 1u] = mean.y; pixels[8u * pix + 2u] = mean.z;
    pixels[8u * pix + 3u] = f32(end);
    pixels[8u * pix + 4u] = m2.x; pixels[8u * pix + 5u] = m2.y; pixels[8u * pix + 6u] = m2.z;
    pixels[8u * pix + 7u] = flagged;
    if STATS {
        for (var c = 0u; c < N_COUNTERS; c++) { counts[COUNT_WORDS * pix + c] = counters[c]; }
        counts[COUNT_WORDS * pix + 15u] = first_prim;
    }
}
