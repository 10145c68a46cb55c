// The sample positions and camera rays: SplitMix64 in 32-bit halves, the
// samplers, vector helpers, rays (part of the shader; see common.wgsl).

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

