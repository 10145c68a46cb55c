// Hits, Whitted's shading and the integrator's loop, and the entry point
// (part of the shader; see common.wgsl).

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
