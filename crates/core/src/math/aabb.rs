//! The axis-aligned box: bounds of primitives and scenes, the BVH's box
//! volume, the voxel grid's extent. One type, and one slab test in several
//! forms: [`Aabb::slab`] for one box, [`slab4`], its 4-lane SIMD form, for
//! four boxes at once (the BVH's packed sibling pairs and 4-wide nodes),
//! and [`slab8`] / [`slab8_avx2`] for the eight boxes of an 8-wide node
//! ([`slab8_with`] picks one by the capability it is given, [`super::isa`]).
//! All do the same operations in the same order, so they give
//! bit-identical distances (tested below).

use super::isa::{Avx2, Isa};
use glam::{BVec4A, Vec3, Vec3A, Vec4};

/// An axis-aligned box [min, max]. Empty when some min exceeds its max
/// ([`Aabb::EMPTY`] is the identity of [`Aabb::union`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

/// ε = 2⁻²⁴, the largest relative error of one rounded f32 operation.
const UNIT_ROUNDOFF: f32 = f32::EPSILON * 0.5;

/// Ize's bound for the slab test ("Robust BVH Ray Traversal", JCGT 2(2),
/// 2013, §3): scaling the exit distance by 1 + 2γ₃, γₙ = nε/(1 − nε), makes
/// the computed interval overlap the exact one whenever the exact one is not
/// empty, so rays through edges and corners of a box are never lost.
pub const SLAB_EXIT_SCALE: f32 = 1.0 + 2.0 * (3.0 * UNIT_ROUNDOFF / (1.0 - 3.0 * UNIT_ROUNDOFF));

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    #[inline]
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline]
    pub fn include(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[inline]
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    #[inline]
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Corner `i` of 8: bit 0 of `i` picks max x over min x, bit 1 y, bit 2 z.
    pub fn corner(&self, i: usize) -> Vec3 {
        let pick = |bit: usize, lo: f32, hi: f32| if i & bit == 0 { lo } else { hi };
        Vec3::new(
            pick(1, self.min.x, self.max.x),
            pick(2, self.min.y, self.max.y),
            pick(4, self.min.z, self.max.z),
        )
    }

    /// Surface area (0 for an empty box).
    #[inline]
    pub fn surface_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Enclosed volume (0 for an empty box).
    pub fn volume(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        e.x * e.y * e.z
    }

    // ANCHOR: slab
    /// Slab test (Kay & Kajiya 1986) of the ray `origin + t·d`, given
    /// `inv_dir` = 1/d: per axis the ray is inside the slab for t between
    /// (min − o)/d and (max − o)/d; the box is hit where the three intervals
    /// overlap. Returns the entry distance clamped to 0 (a ray starting
    /// inside enters at 0) when the box is met somewhere in [0, `t_max`].
    /// The exit is scaled by [`SLAB_EXIT_SCALE`], so the test is
    /// conservative.
    #[inline]
    pub fn slab(&self, origin: Vec3, inv_dir: Vec3, t_max: f32) -> Option<f32> {
        // The three axes side by side in one SIMD register (`Vec3A`): each
        // step below is one instruction for all three.
        let (o, inv) = (Vec3A::from(origin), Vec3A::from(inv_dir));
        let t0 = (Vec3A::from(self.min) - o) * inv;
        let t1 = (Vec3A::from(self.max) - o) * inv;
        // 0·∞ = NaN arises only when the ray is parallel to an axis (1/d =
        // ±∞) and starts exactly on one of that slab's planes: it then stays
        // in the closed slab for every t, so that axis must not constrain
        // the interval. Replace its bounds by (−∞, +∞) explicitly rather
        // than relying on how min/max treat NaN.
        let free = t0.is_nan_mask() | t1.is_nan_mask();
        let near = Vec3A::select(free, Vec3A::NEG_INFINITY, t0.min(t1));
        let far = Vec3A::select(free, Vec3A::INFINITY, t0.max(t1));
        let t_enter = near.max_element();
        let t_exit = far.min_element() * SLAB_EXIT_SCALE;
        (t_enter <= t_exit && t_exit >= 0.0 && t_enter <= t_max).then_some(t_enter.max(0.0))
    }
    // ANCHOR_END: slab
}

/// [`Aabb::slab`] for four boxes at once, lane i being box i: `lo[a]` and
/// `hi[a]` hold the boxes' two planes along axis a (either may be the min:
/// the test takes the smaller distance as the entry). Returns the entry
/// distances clamped to 0 and a bit mask of the lanes whose box is hit in
/// [0, `t_max`]; each lane's result is bit-identical to [`Aabb::slab`].
#[inline(always)]
pub fn slab4(
    lo: &[Vec4; 3],
    hi: &[Vec4; 3],
    origin: Vec3,
    inv_dir: Vec3,
    t_max: f32,
) -> (Vec4, u32) {
    let o = origin.to_array();
    let inv = inv_dir.to_array();
    let dist = |planes: &[Vec4; 3]| -> [Vec4; 3] {
        std::array::from_fn(|a| (planes[a] - Vec4::splat(o[a])) * Vec4::splat(inv[a]))
    };
    slab4_distances(&dist(lo), &dist(hi), t_max)
}

/// The interval logic of [`slab4`] from the plane distances themselves,
/// t0 = (lo − o)/d and t1 = (hi − o)/d per axis: a caller that gets both
/// planes of a pair of boxes from one set of lanes (the binary BVH's packed
/// siblings) computes the distances once and swizzles them.
#[inline(always)]
pub fn slab4_distances(t0: &[Vec4; 3], t1: &[Vec4; 3], t_max: f32) -> (Vec4, u32) {
    let mut enter = Vec4::NEG_INFINITY;
    let mut exit = Vec4::INFINITY;
    for a in 0..3 {
        // As in `Aabb::slab`: a NaN (parallel ray starting on a plane)
        // frees the axis.
        let free: BVec4A = t0[a].is_nan_mask() | t1[a].is_nan_mask();
        enter = enter.max(Vec4::select(free, Vec4::NEG_INFINITY, t0[a].min(t1[a])));
        exit = exit.min(Vec4::select(free, Vec4::INFINITY, t0[a].max(t1[a])));
    }
    let exit = exit * SLAB_EXIT_SCALE;
    let ok = enter.cmple(exit) & exit.cmpge(Vec4::ZERO) & enter.cmple(Vec4::splat(t_max));
    (enter.max(Vec4::ZERO), ok.bitmask())
}

/// Eight boxes' planes, lane i being box i (the 8-wide BVH's node layout).
pub type Planes8 = [[f32; 8]; 3];

/// [`slab4`] for eight boxes at once, without AVX: the two halves through
/// [`slab4`]. Bit-identical to [`Aabb::slab`] lane by lane, as
/// [`slab8_avx2`] is.
#[inline(always)]
pub fn slab8(
    lo: &Planes8,
    hi: &Planes8,
    origin: Vec3,
    inv_dir: Vec3,
    t_max: f32,
) -> ([f32; 8], u32) {
    let half = |p: &Planes8, h: usize| -> [Vec4; 3] {
        std::array::from_fn(|a| Vec4::from_slice(&p[a][4 * h..4 * h + 4]))
    };
    let (e0, m0) = slab4(&half(lo, 0), &half(hi, 0), origin, inv_dir, t_max);
    let (e1, m1) = slab4(&half(lo, 1), &half(hi, 1), origin, inv_dir, t_max);
    let mut enter = [0.0; 8];
    enter[..4].copy_from_slice(&e0.to_array());
    enter[4..].copy_from_slice(&e1.to_array());
    (enter, m0 | m1 << 4)
}

/// [`slab8`] in AVX registers: the operations of [`slab4_distances`], in
/// the same order and with the same operand order (so NaN and signed-zero
/// cases resolve alike), on eight lanes. `avx2` is the proof that the CPU
/// runs them ([`Avx2::detect`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn slab8_avx2(
    avx2: Avx2,
    lo: &Planes8,
    hi: &Planes8,
    origin: Vec3,
    inv_dir: Vec3,
    t_max: f32,
) -> ([f32; 8], u32) {
    let _ = avx2;
    // SAFETY: the function is compiled for AVX2, which `avx2`, a token only
    // `Avx2::detect` makes, proves this CPU has.
    unsafe { slab8_in_avx2(lo, hi, origin, inv_dir, t_max) }
}

/// The body of [`slab8_avx2`], compiled for AVX2 (so inlined into code
/// compiled for it, such as the wide trees' AVX2 traversal).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn slab8_in_avx2(
    lo: &Planes8,
    hi: &Planes8,
    origin: Vec3,
    inv_dir: Vec3,
    t_max: f32,
) -> ([f32; 8], u32) {
    use std::arch::x86_64::*;
    // SAFETY: `p` points to 8 readable `f32`s (32 bytes); `loadu` needs no
    // alignment.
    let load = |p: &[f32; 8]| unsafe { _mm256_loadu_ps(p.as_ptr()) };
    let mut enter = _mm256_set1_ps(f32::NEG_INFINITY);
    let mut exit = _mm256_set1_ps(f32::INFINITY);
    for a in 0..3 {
        let o = _mm256_set1_ps(origin[a]);
        let inv = _mm256_set1_ps(inv_dir[a]);
        let t0 = _mm256_mul_ps(_mm256_sub_ps(load(&lo[a]), o), inv);
        let t1 = _mm256_mul_ps(_mm256_sub_ps(load(&hi[a]), o), inv);
        let free = _mm256_or_ps(
            _mm256_cmp_ps::<_CMP_UNORD_Q>(t0, t0),
            _mm256_cmp_ps::<_CMP_UNORD_Q>(t1, t1),
        );
        // select(free, a, b) = blendv(b, a, free), as glam's SSE select.
        let near = _mm256_blendv_ps(
            _mm256_min_ps(t0, t1),
            _mm256_set1_ps(f32::NEG_INFINITY),
            free,
        );
        let far = _mm256_blendv_ps(_mm256_max_ps(t0, t1), _mm256_set1_ps(f32::INFINITY), free);
        enter = _mm256_max_ps(enter, near);
        exit = _mm256_min_ps(exit, far);
    }
    let exit = _mm256_mul_ps(exit, _mm256_set1_ps(SLAB_EXIT_SCALE));
    let zero = _mm256_setzero_ps();
    let ok = _mm256_and_ps(
        _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LE_OQ>(enter, exit),
            _mm256_cmp_ps::<_CMP_GE_OQ>(exit, zero),
        ),
        _mm256_cmp_ps::<_CMP_LE_OQ>(enter, _mm256_set1_ps(t_max)),
    );
    let enter = _mm256_max_ps(enter, zero);
    let mut out = [0.0f32; 8];
    // SAFETY: `out` is 8 writable `f32`s (32 bytes); `storeu` needs no
    // alignment.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), enter) };
    (out, _mm256_movemask_ps(ok) as u32)
}

/// The 8-wide slab test in the form `isa` allows: [`slab8_avx2`] with an
/// [`Avx2`] token, [`slab8`] with [`Baseline`](super::Baseline). The
/// choice is made at compile time (the capability's type), and both give
/// the same bits.
#[inline(always)]
pub fn slab8_with<I: Isa>(
    isa: I,
    lo: &Planes8,
    hi: &Planes8,
    origin: Vec3,
    inv_dir: Vec3,
    t_max: f32,
) -> ([f32; 8], u32) {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = isa.avx2() {
        return slab8_avx2(avx2, lo, hi, origin, inv_dir, t_max);
    }
    let _ = isa;
    slab8(lo, hi, origin, inv_dir, t_max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::SplitMix64;

    /// Entry distances and hit mask of one N-lane form of the slab test.
    type Form<'a, const N: usize> = &'a dyn Fn(&[Aabb; N], Vec3, Vec3, f32) -> ([f32; N], u32);

    /// Every `forms` must agree with the scalar slab bit for bit, whatever
    /// the ray: random boxes, random rays, axis-parallel rays (infinite
    /// 1/d) and rays starting exactly on a box's plane (the NaN case).
    /// Returns the number of hits checked.
    fn check_against_scalar<const N: usize>(seed: u64, forms: &[Form<N>]) -> usize {
        let mut rng = SplitMix64(seed);
        let v = |rng: &mut SplitMix64| {
            Vec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
            )
        };
        let mut hits = 0;
        for i in 0..20_000 {
            let boxes: [Aabb; N] = std::array::from_fn(|_| {
                let (a, b) = (v(&mut rng), v(&mut rng));
                Aabb {
                    min: a.min(b),
                    max: a.max(b),
                }
            });
            let mut origin = v(&mut rng);
            let mut dir = v(&mut rng);
            let axis = (i / 4) % 3;
            match i % 4 {
                1 => dir[axis] = 0.0,
                2 => {
                    dir[axis] = 0.0;
                    let b = &boxes[i % N];
                    origin[axis] = if i % 8 < 4 { b.min[axis] } else { b.max[axis] };
                }
                _ => {}
            }
            let inv = dir.recip();
            let t_max = rng.range(0.0, 4.0);
            for form in forms {
                let (enter, mask) = form(&boxes, origin, inv, t_max);
                for (k, b) in boxes.iter().enumerate() {
                    let scalar = b.slab(origin, inv, t_max);
                    assert_eq!(mask & (1 << k) != 0, scalar.is_some(), "ray {i} box {k}");
                    if let Some(t) = scalar {
                        assert_eq!(enter[k].to_bits(), t.to_bits(), "ray {i} box {k}");
                        hits += 1;
                    }
                }
            }
        }
        hits
    }

    #[test]
    fn slab4_is_bit_identical_to_the_scalar_slab() {
        let form = |boxes: &[Aabb; 4], o: Vec3, inv: Vec3, t_max: f32| {
            let lane = |f: fn(&Aabb) -> Vec3, a: usize| {
                Vec4::from_array(std::array::from_fn(|k| f(&boxes[k])[a]))
            };
            let lo = [0, 1, 2].map(|a| lane(|b| b.min, a));
            let hi = [0, 1, 2].map(|a| lane(|b| b.max, a));
            let (enter, mask) = slab4(&lo, &hi, o, inv, t_max);
            (enter.to_array(), mask)
        };
        let hits = check_against_scalar::<4>(5, &[&form]);
        assert!(hits > 5_000, "too few hits ({hits}) to test anything");
    }

    /// Both 8-wide forms (the AVX2 one where the CPU has AVX2; the test
    /// says which it checked).
    #[test]
    fn slab8_is_bit_identical_to_the_scalar_slab() {
        let planes = |boxes: &[Aabb; 8], f: fn(&Aabb) -> Vec3| -> Planes8 {
            std::array::from_fn(|a| std::array::from_fn(|k| f(&boxes[k])[a]))
        };
        let portable = |boxes: &[Aabb; 8], o: Vec3, inv: Vec3, t_max: f32| {
            slab8(
                &planes(boxes, |b| b.min),
                &planes(boxes, |b| b.max),
                o,
                inv,
                t_max,
            )
        };
        let mut forms: Vec<Form<8>> = vec![&portable];
        let avx2 = Avx2::detect();
        let simd = |boxes: &[Aabb; 8], o: Vec3, inv: Vec3, t_max: f32| {
            let (lo, hi) = (planes(boxes, |b| b.min), planes(boxes, |b| b.max));
            // Reached only with a token (the `if` below).
            slab8_with(avx2.unwrap(), &lo, &hi, o, inv, t_max)
        };
        if avx2.is_some() {
            forms.push(&simd);
        }
        let avx2 = avx2.is_some();
        eprintln!("slab8: portable form checked; AVX2 form checked: {avx2}");
        let hits = check_against_scalar::<8>(8, &forms);
        assert!(hits > 10_000, "too few hits ({hits}) to test anything");
    }
}
