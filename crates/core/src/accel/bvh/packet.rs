//! SIMD leaves: a wide tree's leaf of triangles stored as packets of as
//! many triangles as the tree is wide (four for `bvh4`, eight for `bvh8`),
//! one array per vertex coordinate, and tested together with the
//! watertight test of [`Triangle::intersect`].
//!
//! Bit-identical hits: every lane performs the scalar test's operations in
//! the same order on the same `f32` values (Rust never fuses a multiply and
//! an add on its own), so each lane's edge functions, determinant and
//! scaled distance are the scalar test's bit for bit. Two parts of the
//! scalar test are not lane-parallel, and the packet test reproduces them
//! exactly rather than approximately:
//! - an edge function that rounds to exactly zero is recomputed in `f64`
//!   by the scalar test; a packet with such a lane is handed to the scalar
//!   loop as a whole (it happens on edge-aimed rays, not in bulk). So is a
//!   packet with a NaN edge function, or three whose product underflows:
//!   on the other lanes the edge functions are non-zero numbers, and two
//!   of the scalar test's checks take fewer instructions in exact
//!   equivalents (the sign test on the sign bits, the interval check for
//!   a negative determinant as the positive one's on negated values);
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
//!
//! Instructions: the tests take a capability ([`crate::math::isa`]); with
//! an [`Avx2`](crate::math::Avx2) token the 8-lane masks are one AVX
//! `movmskps`, and called from code compiled for AVX2 (the wide trees'
//! AVX2 traversal) the lanes' arithmetic is 8-wide.

use crate::accel::brute::{any_of, closest_of};
use crate::math::Isa;
use crate::shape::{PreparedRay, PrimHit, Triangle};
use crate::stats::Stats;

/// Up to `L` triangles of one leaf (`L` = 4 for the 4-wide tree, 8 for the
/// 8-wide one), lane i being slot `slot + i` of the tree's leaf order.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
pub struct TriPacket<const L: usize> {
    /// `p[v][a][i]`: coordinate `a` of vertex `v` of triangle `i`.
    pub p: [[[f32; L]; 3]; 3],
    /// The leaf-order slot of lane 0.
    pub slot: u32,
    /// Lanes in use (1..=L); unused lanes repeat the last triangle.
    pub lanes: u32,
}

impl<const L: usize> TriPacket<L> {
    /// The packet of `tris[slot..slot + lanes]` (1 ≤ lanes ≤ L).
    pub fn new(tris: &[Triangle], slot: usize, lanes: usize) -> Self {
        debug_assert!((1..=L).contains(&lanes) && L <= 32);
        let tri = |i: usize| &tris[slot + i.min(lanes - 1)];
        TriPacket {
            p: std::array::from_fn(|v| {
                std::array::from_fn(|a| std::array::from_fn(|i| tri(i).p[v][a]))
            }),
            slot: slot as u32,
            lanes: lanes as u32,
        }
    }

    /// Slots `first..first + count` of `tris` as packets of `L`.
    pub fn pack(tris: &[Triangle], first: usize, count: usize, out: &mut Vec<Self>) {
        for start in (first..first + count).step_by(L) {
            out.push(TriPacket::new(tris, start, (first + count - start).min(L)));
        }
    }

    /// Mask of the lanes in use.
    #[inline(always)]
    fn valid(&self) -> u32 {
        (1u32 << self.lanes) - 1
    }
}

/// The lane-parallel part of the watertight test.
struct Lanes<const L: usize> {
    /// Edge functions: the scaled barycentrics of vertices 1 and 2 (that
    /// of vertex 0 only enters `det` and `t_scaled`).
    v: [f32; L],
    w: [f32; L],
    det: [f32; L],
    t_scaled: [f32; L],
    /// Lanes that pass the test with the `t_max` given.
    hit: u32,
}

/// The watertight test on the `L` lanes, or `None` when a valid lane has
/// an edge function of exactly zero (the scalar test's `f64` case) or is
/// otherwise odd (below).
///
/// Written lane by lane over fixed-length arrays, with no branch in the
/// loop, so that the compiler turns each line into one SIMD instruction
/// over the lanes (4-wide SSE, or 8-wide AVX2 inside the AVX2 traversal);
/// each lane's operations are the scalar test's, in its order.
#[inline(always)]
fn lanes<const L: usize, I: Isa>(
    isa: I,
    pk: &TriPacket<L>,
    r: &PreparedRay,
    t_max: f32,
) -> Option<Lanes<L>> {
    let (kx, ky, kz) = (r.kx, r.ky, r.kz);
    let o = r.ray.origin.to_array();
    let (ox, oy, oz) = (o[kx], o[ky], o[kz]);
    let s = r.shear;
    let (px, py, pz) = (&pk.p[0], &pk.p[1], &pk.p[2]);
    let mut out = Lanes {
        v: [0.0; L],
        w: [0.0; L],
        det: [0.0; L],
        t_scaled: [0.0; L],
        hit: 0,
    };
    // Lane masks, all ones where true (what a SIMD comparison yields).
    let mut odd = [0u32; L];
    let mut miss = [0u32; L];
    for i in 0..L {
        // Vertex `p` relative to the ray origin, sheared.
        let sheared = |p: &[[f32; L]; 3]| {
            let (x, y, z) = (p[kx][i] - ox, p[ky][i] - oy, p[kz][i] - oz);
            (x - s.x * z, y - s.y * z, s.z * z)
        };
        let (ax, ay, az) = sheared(px);
        let (bx, by, bz) = sheared(py);
        let (cx, cy, cz) = sheared(pz);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        // The lanes left to the scalar test: an edge function of zero (which
        // it redoes in f64), and so that the shortcuts below are exact,
        // any NaN (or a product that underflows to zero); `!(x > 0)` is
        // true for NaN, which is the point. On the other lanes u, v and w
        // are non-zero numbers, so:
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let odd_lane = !((u * v * w).abs() > 0.0);
        odd[i] = lane_mask(odd_lane);
        // - the scalar test's "some negative and some positive" is "the
        //   signs differ";
        let mixed = ((u.to_bits() ^ v.to_bits()) | (v.to_bits() ^ w.to_bits())) >> 31 != 0;
        let det = u + v + w;
        let t_scaled = u * az + v * bz + w * cz;
        let limit = t_max * det;
        // - its interval check for det < 0, (t ≥ 0 or t ≤ limit), is the
        //   one for det > 0, (t ≤ 0 or t ≥ limit), on −t and −limit
        //   (negation is exact); det = ±0 is a miss either way.
        let flip = det.to_bits() & 0x8000_0000;
        let t_signed = f32::from_bits(t_scaled.to_bits() ^ flip);
        let limit_signed = f32::from_bits(limit.to_bits() ^ flip);
        let outside = (t_signed <= 0.0) | (t_signed >= limit_signed);
        miss[i] = lane_mask(mixed | (det == 0.0) | outside);
        out.v[i] = v;
        out.w[i] = w;
        out.det[i] = det;
        out.t_scaled[i] = t_scaled;
    }
    let valid = pk.valid();
    if bits(isa, &odd) & valid != 0 {
        return None;
    }
    out.hit = !bits(isa, &miss) & valid;
    Some(out)
}

/// All ones where `b`, as a SIMD comparison leaves a lane.
#[inline(always)]
fn lane_mask(b: bool) -> u32 {
    0u32.wrapping_sub(u32::from(b))
}

/// Bit i set where lane i of `m` is all ones: one `movmskps` on x86-64 (the
/// 8-lane one with an AVX2 token in `isa`), otherwise a loop. Packing the
/// lanes' bits by shifts and ors costs a dozen instructions per mask,
/// which a leaf test pays twice.
#[inline(always)]
fn bits<const L: usize, I: Isa>(isa: I, m: &[u32; L]) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm256_loadu_ps, _mm256_movemask_ps, _mm_loadu_ps, _mm_movemask_ps,
        };
        if L == 4 {
            // SAFETY: SSE is part of x86-64; `m` holds 4 lanes of 4 bytes,
            // which `loadu` reads without an alignment requirement.
            let v = unsafe { _mm_loadu_ps(m.as_ptr().cast()) };
            // SAFETY: SSE is part of x86-64.
            return unsafe { _mm_movemask_ps(v) } as u32;
        }
        if let (8, Some(_avx2)) = (L, isa.avx2()) {
            // SAFETY: AVX, which AVX2 implies and `_avx2` proves (a token
            // only `Avx2::detect` makes); `m` holds 8 lanes of 4 bytes,
            // which `loadu` reads without an alignment requirement.
            let v = unsafe { _mm256_loadu_ps(m.as_ptr().cast()) };
            // SAFETY: AVX, as for the load.
            return unsafe { _mm256_movemask_ps(v) } as u32;
        }
    }
    let _ = isa;
    m.iter()
        .enumerate()
        .fold(0, |acc, (i, &x)| acc | ((x & 1) << i))
}

/// The scalar test's last step for one lane ([`Triangle::finish`]): its
/// interval check against the current `t_max` and the division.
#[inline(always)]
fn accept<const L: usize>(l: &Lanes<L>, i: usize, t_max: f32) -> Option<PrimHit> {
    Triangle::finish(l.v[i], l.w[i], l.det[i], l.t_scaled[i], t_max)
}

/// Closest hit among the packets of one leaf, as [`closest_of`] over its
/// triangles in slot order would find it, with the instructions `isa`
/// allows. `tris` and `indices` are the tree's leaf-ordered triangles and
/// scene indices.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the scalar loop's seven, and `isa`
pub fn closest_in_packets<S: Stats, const L: usize, I: Isa>(
    isa: I,
    packets: &[TriPacket<L>],
    tris: &[Triangle],
    indices: &[u32],
    ray: &PreparedRay,
    t_max: &mut f32,
    best: &mut Option<(u32, PrimHit)>,
    stats: &mut S,
) {
    for pk in packets {
        let slot = pk.slot as usize;
        let Some(l) = lanes(isa, pk, ray, *t_max) else {
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
/// the first packet with a hit, as [`any_of`] decides it (`isa` as for
/// [`closest_in_packets`]).
#[inline(always)]
pub fn any_in_packets<S: Stats, const L: usize, I: Isa>(
    isa: I,
    packets: &[TriPacket<L>],
    tris: &[Triangle],
    ray: &PreparedRay,
    t_max: f32,
    stats: &mut S,
) -> bool {
    for pk in packets {
        let slot = pk.slot as usize;
        let Some(l) = lanes(isa, pk, ray, t_max) else {
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
    use crate::math::{Avx2, Baseline, Ray, SplitMix64, Vec3};
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
        check::<4, _>(Baseline);
        check::<8, _>(Baseline);
        if let Some(avx2) = Avx2::detect() {
            check::<4, _>(avx2);
            check::<8, _>(avx2);
        }
    }

    fn check<const L: usize, I: Isa>(isa: I) {
        let mut rng = SplitMix64(19);
        let (mut hits, mut exact) = (0, 0);
        for case in 0..4000 {
            // One to two and a half packets.
            let n = 1 + case % (2 * L + L / 2);
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
            let mut packets = Vec::<TriPacket<L>>::new();
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
            closest_in_packets::<_, L, _>(
                isa,
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
            assert_eq!(bits(best_s), bits(best_p), "{L} lanes, case {case}");
            assert_eq!(t_s.to_bits(), t_p.to_bits(), "{L} lanes, case {case}");
            assert_eq!(st_s, st_p, "{L} lanes, case {case}");
            hits += usize::from(best_s.is_some());
            exact += usize::from(
                packets
                    .iter()
                    .any(|pk| lanes(isa, pk, &ray, t_max).is_none()),
            );

            let (mut a_s, mut a_p) = (Counters::default(), Counters::default());
            let any_s = any_of(tris.iter(), &ray, t_max, &mut a_s);
            let any_p = any_in_packets::<_, L, _>(isa, &packets, &tris, &ray, t_max, &mut a_p);
            assert_eq!(any_s, any_p, "{L} lanes, case {case}");
            assert_eq!(a_s, a_p, "{L} lanes, case {case}");
        }
        assert!(hits > 1000, "only {hits} hits");
        assert!(exact > 10, "only {exact} cases took the f64 path");
    }
}
