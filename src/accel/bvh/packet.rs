//! SIMD leaves: a wide tree's leaf of triangles stored as packets of four,
//! one 4-lane vector per vertex coordinate, and tested four at a time with
//! the watertight test of [`Triangle::intersect`].
//!
//! Bit-identical hits: every lane performs the scalar test's operations in
//! the same order on the same `f32` values (Rust never fuses a multiply and
//! an add on its own), so each lane's edge functions, determinant and
//! scaled distance are the scalar test's bit for bit. Two parts of the
//! scalar test are not lane-parallel, and the packet test reproduces them
//! exactly rather than approximately:
//! - an edge function that rounds to exactly zero is recomputed in `f64`
//!   by the scalar test; a packet with such a lane is handed to the scalar
//!   loop as a whole (it happens on edge-aimed rays, not in bulk);
//! - the scalar closest-hit loop tests triangles one after another with
//!   `t_max` shrinking as hits are found. The packet filters all lanes
//!   against the `t_max` it starts with (a lane rejected then is rejected
//!   by any smaller `t_max`: the rounded product `t_max·det` is monotone in
//!   `t_max`), then accepts the survivors in lane order with the scalar
//!   test's own comparison and division. So the hit, its `t` and its
//!   barycentrics are the scalar loop's, ties included.
//!
//! Counting: one triangle test per valid lane tested, one primitive hit per
//! accepted improvement, as the scalar loop counts.

use crate::accel::brute::{any_of, closest_of};
use crate::shape::{PreparedRay, PrimHit, Triangle};
use crate::stats::Stats;
use glam::{BVec4A, Vec4};

/// Up to four triangles of one leaf, lane i being slot `slot + i` of the
/// tree's leaf order.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
pub struct TriPacket {
    /// `p[v][a]`: coordinate `a` of vertex `v` of the four triangles.
    pub p: [[Vec4; 3]; 3],
    /// The leaf-order slot of lane 0.
    pub slot: u32,
    /// Lanes in use (1..=4); unused lanes repeat the last triangle.
    pub lanes: u32,
}

impl TriPacket {
    /// The packet of `tris[slot..slot + lanes]` (1 ≤ lanes ≤ 4).
    pub fn new(tris: &[Triangle], slot: usize, lanes: usize) -> Self {
        debug_assert!((1..=4).contains(&lanes));
        let tri = |i: usize| &tris[slot + i.min(lanes - 1)];
        TriPacket {
            p: std::array::from_fn(|v| {
                std::array::from_fn(|a| Vec4::from_array(std::array::from_fn(|i| tri(i).p[v][a])))
            }),
            slot: slot as u32,
            lanes: lanes as u32,
        }
    }

    /// Slots `first..first + count` of `tris` as packets of four.
    pub fn pack(tris: &[Triangle], first: usize, count: usize, out: &mut Vec<TriPacket>) {
        for start in (first..first + count).step_by(4) {
            out.push(TriPacket::new(tris, start, (first + count - start).min(4)));
        }
    }

    /// Mask of the lanes in use.
    #[inline(always)]
    fn valid(&self) -> u32 {
        (1u32 << self.lanes) - 1
    }
}

/// The lane-parallel part of the watertight test.
struct Lanes {
    /// Edge functions: the scaled barycentrics of vertices 1 and 2 (that
    /// of vertex 0 only enters `det` and `t_scaled`).
    v: Vec4,
    w: Vec4,
    det: Vec4,
    t_scaled: Vec4,
    /// Lanes that pass the test with the `t_max` given.
    hit: u32,
}

/// The watertight test on the four lanes, or `None` when a valid lane has
/// an edge function of exactly zero (the scalar test's `f64` case).
#[inline(always)]
fn lanes(pk: &TriPacket, r: &PreparedRay, t_max: f32) -> Option<Lanes> {
    let (kx, ky, kz) = (r.kx, r.ky, r.kz);
    let o = r.ray.origin;
    let s = r.shear;
    // Vertex v relative to the ray origin, along axis a.
    let rel = |v: usize, a: usize| pk.p[v][a] - Vec4::splat(o[a]);
    let (sx, sy, sz) = (Vec4::splat(s.x), Vec4::splat(s.y), Vec4::splat(s.z));
    let sheared = |v: usize| {
        let (x, y, z) = (rel(v, kx), rel(v, ky), rel(v, kz));
        (x - sx * z, y - sy * z, sz * z)
    };
    let (ax, ay, az) = sheared(0);
    let (bx, by, bz) = sheared(1);
    let (cx, cy, cz) = sheared(2);
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let zero = Vec4::ZERO;
    let valid = pk.valid();
    if (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask() & valid != 0 {
        return None;
    }
    let negative = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
    let positive = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
    let det = u + v + w;
    let t_scaled = u * az + v * bz + w * cz;
    let limit = Vec4::splat(t_max) * det;
    let forward: BVec4A = det.cmpgt(zero);
    let reject_forward = forward & (t_scaled.cmple(zero) | t_scaled.cmpge(limit));
    let reject_backward = !forward & (t_scaled.cmpge(zero) | t_scaled.cmple(limit));
    let miss = (negative & positive) | det.cmpeq(zero) | reject_forward | reject_backward;
    Some(Lanes {
        v,
        w,
        det,
        t_scaled,
        hit: !miss.bitmask() & valid,
    })
}

/// The scalar test's last step for one lane ([`Triangle::finish`]): its
/// interval check against the current `t_max` and the division.
#[inline(always)]
fn accept(l: &Lanes, i: usize, t_max: f32) -> Option<PrimHit> {
    Triangle::finish(l.v[i], l.w[i], l.det[i], l.t_scaled[i], t_max)
}

/// Closest hit among the packets of one leaf, as [`closest_of`] over its
/// triangles in slot order would find it. `tris` and `indices` are the
/// tree's leaf-ordered triangles and scene indices.
#[inline(always)]
pub fn closest_in_packets<S: Stats>(
    packets: &[TriPacket],
    tris: &[Triangle],
    indices: &[u32],
    ray: &PreparedRay,
    t_max: &mut f32,
    best: &mut Option<(u32, PrimHit)>,
    stats: &mut S,
) {
    for pk in packets {
        let slot = pk.slot as usize;
        let Some(l) = lanes(pk, ray, *t_max) else {
            let range = slot..slot + pk.lanes as usize;
            let ids = indices[range.clone()].iter().copied();
            closest_of(ids.zip(&tris[range]), ray, t_max, best, stats);
            continue;
        };
        stats.triangles_tested(pk.lanes);
        let mut hit = l.hit;
        while hit != 0 {
            let i = hit.trailing_zeros() as usize;
            hit &= hit - 1;
            if let Some(h) = accept(&l, i, *t_max) {
                stats.primitive_hit();
                *t_max = h.t;
                *best = Some((indices[slot + i], h));
            }
        }
    }
}

/// Whether any triangle of the packets is hit in (0, t_max), stopping at
/// the first packet with a hit, as [`any_of`] decides it.
#[inline(always)]
pub fn any_in_packets<S: Stats>(
    packets: &[TriPacket],
    tris: &[Triangle],
    ray: &PreparedRay,
    t_max: f32,
    stats: &mut S,
) -> bool {
    for pk in packets {
        let slot = pk.slot as usize;
        let Some(l) = lanes(pk, ray, t_max) else {
            if any_of(
                tris[slot..slot + pk.lanes as usize].iter(),
                ray,
                t_max,
                stats,
            ) {
                return true;
            }
            continue;
        };
        // The scalar loop stops at its first hit: count the lanes it would
        // have tested.
        if l.hit != 0 {
            stats.triangles_tested(l.hit.trailing_zeros() + 1);
            stats.primitive_hit();
            return true;
        }
        stats.triangles_tested(pk.lanes);
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Ray, SplitMix64, Vec3};
    use crate::stats::Counters;

    fn v(rng: &mut SplitMix64, r: f32) -> Vec3 {
        Vec3::new(rng.range(-r, r), rng.range(-r, r), rng.range(-r, r))
    }

    /// Packets find exactly what the scalar loops find (same triangle, same
    /// bits of t, u, v; same counts) on random triangles, on rays aimed at
    /// their vertices and edges, on triangles sharing a vertex, and with
    /// partly filled packets.
    #[test]
    fn packets_match_the_scalar_loops_bit_for_bit() {
        let mut rng = SplitMix64(19);
        let (mut hits, mut exact) = (0, 0);
        for case in 0..4000 {
            let n = 1 + case % 7;
            let shared = v(&mut rng, 1.0);
            let tris: Vec<Triangle> = (0..n)
                .map(|k| {
                    let p0 = if case % 3 == 0 {
                        shared
                    } else {
                        v(&mut rng, 1.0)
                    };
                    let (p1, p2) = if k % 5 == 4 {
                        // A degenerate (flat) triangle.
                        let q = v(&mut rng, 1.0);
                        (q, p0 + 0.5 * (q - p0))
                    } else {
                        (v(&mut rng, 1.0), v(&mut rng, 1.0))
                    };
                    Triangle::new(p0, p1, p2)
                })
                .collect();
            let indices: Vec<u32> = (0..n as u32).map(|k| 100 + k).collect();
            let mut packets = Vec::new();
            TriPacket::pack(&tris, 0, n, &mut packets);
            let origin = v(&mut rng, 3.0);
            let target = match case % 4 {
                0 => tris[case % n].p[case % 3],
                1 => {
                    let t = &tris[case % n];
                    let s = rng.range(0.0, 1.0);
                    t.p[0] + s * (t.p[1] - t.p[0])
                }
                _ => v(&mut rng, 0.5),
            };
            let ray = PreparedRay::new(Ray::new(origin, target - origin));
            let t_max = if case % 2 == 0 {
                f32::INFINITY
            } else {
                rng.range(0.5, 4.0)
            };

            let (mut t_s, mut best_s, mut st_s) = (t_max, None, Counters::default());
            let ids = indices.iter().copied();
            closest_of(ids.zip(&tris), &ray, &mut t_s, &mut best_s, &mut st_s);
            let (mut t_p, mut best_p, mut st_p) = (t_max, None, Counters::default());
            closest_in_packets(
                &packets,
                &tris,
                &indices,
                &ray,
                &mut t_p,
                &mut best_p,
                &mut st_p,
            );
            let bits = |b: Option<(u32, PrimHit)>| {
                b.map(|(i, h)| (i, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()))
            };
            assert_eq!(bits(best_s), bits(best_p), "case {case}");
            assert_eq!(t_s.to_bits(), t_p.to_bits(), "case {case}");
            assert_eq!(st_s, st_p, "case {case}");
            hits += usize::from(best_s.is_some());
            exact += usize::from(packets.iter().any(|pk| lanes(pk, &ray, t_max).is_none()));

            let (mut a_s, mut a_p) = (Counters::default(), Counters::default());
            let any_s = any_of(tris.iter(), &ray, t_max, &mut a_s);
            let any_p = any_in_packets(&packets, &tris, &ray, t_max, &mut a_p);
            assert_eq!(any_s, any_p, "case {case}");
            assert_eq!(a_s, a_p, "case {case}");
        }
        assert!(hits > 1000, "only {hits} hits");
        assert!(exact > 10, "only {exact} cases took the f64 path");
    }
}
