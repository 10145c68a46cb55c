// Ray–primitive tests, bounding volumes and the traversal of the CPU's
// flattened trees (part of the shader; see common.wgsl).

// ------------------------------------------------------- primitive tests
struct PrimHit { t: f32, u: f32, v: f32 }
const MISS = PrimHit(-1.0, 0.0, 0.0);

// f32::signum: ±1 by the sign bit (signum(+0) = 1, unlike WGSL's sign)
fn signum(x: f32) -> f32 { return select(1.0, -1.0, (bitcast<u32>(x) >> 31u) != 0u); }
// ANCHOR: roots
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
// ANCHOR_END: roots
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
        // bvh::traverse::Pending::pop_live
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

