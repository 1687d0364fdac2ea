//! Sines and cosines of several angles at once, for generated code.
//!
//! The generated functions need `sin q_i` and `cos q_i` of every revolute coordinate
//! (the rotation matrices of eqs. 49–50 and of the recursion behind eqs. 11–16). Through
//! libm that is one `sincos` call per angle, about 12 ns each on the development machine:
//! for a planar 2-link chain the two calls are most of an evaluation of `M` and `F`.
//! [`sin_cos`] evaluates all the angles together with no call and no branch on the data,
//! so the operations of the lanes interleave: measured in `benches/peers`, the fused
//! `evaluate` of the planar 2-link chain went from about 33 ns to about 22 ns, and to about
//! 13–16 ns when the lanes went through SSE2 two at a time (4-link chain: 44 -> 37 ns).
//!
//! Per angle `x` (fdlibm's method, `k_rem_pio2`/`__kernel_sin`/`__kernel_cos`):
//!
//! - reduction: `k = round(x 2/π)`, `r = x − k π/2` with `π/2 = P1 + P2 + P3` (Cody–Waite;
//!   `P1`, `P2` of 33 significant bits, so `k P1` and `k P2` are exact for `|k| < 2^20`);
//! - `sin r = r + r³ S(r²)`, `cos r = 1 − r²/2 + r⁴ C(r²)` on `|r| ≤ π/4` with fdlibm's
//!   minimax coefficients (error below one ulp of the result);
//! - quadrant `k mod 4`: swap and sign changes done on the bit patterns.
//!
//! Arguments with `|x| ≥ 1e5` (and non-finite ones) are handed to libm, lane by lane, so a
//! lane's result never depends on the other lanes: a function that needs `[q1, q2]` and
//! one that needs `[q2]` give bit-identical `sin q2`. The results are within 1 ulp of
//! glibc's `sincos` for `|x| < 1000` and within 2 ulp up to `1e5` (tested below).

// The constants are fdlibm's, written with fdlibm's digits (more than a double holds).
#![allow(clippy::excessive_precision)]

/// `1.5 · 2^52`: adding it rounds a double of magnitude below `2^51` to an integer (round
/// to nearest even) held in the low bits of the sum's bit pattern.
const SHIFT: f64 = 6_755_399_441_055_744.0;
/// First 33 bits of π/2 (fdlibm `pio2_1`).
const P1: f64 = 1.570_796_326_734_125_614_17e+00;
/// Next 33 bits of π/2 (fdlibm `pio2_2`).
const P2: f64 = 6.077_100_506_303_965_976_60e-11;
/// π/2 − P1 − P2 (fdlibm `pio2_2t`).
const P3: f64 = 2.022_266_248_795_950_631_54e-21;
/// Largest magnitude reduced here (`|k| < 2^16`); larger arguments go to libm.
const LIMIT: f64 = 1.0e5;

/// `(sin x_i, cos x_i)` of every lane of `x`: within 1 ulp of libm's `sin_cos` for
/// `|x_i| < 1000`, 2 ulp beyond (libm itself past `1e5`); the same value for a given `x_i`
/// whatever the other lanes hold.
///
/// No call and no branch on the data (but for the far lanes). On x86-64 the lanes go two
/// at a time through SSE2 (part of the baseline, so no run-time detection): the same IEEE
/// operations in the same order as the scalar kernel, lane-wise, so both give the same bits
/// (tested below); an odd last lane and other targets use the scalar kernel.
#[inline(always)]
pub fn sin_cos<const K: usize>(x: [f64; K]) -> ([f64; K], [f64; K]) {
    let mut s = [0.0; K];
    let mut c = [0.0; K];
    let mut i = 0;
    #[cfg(target_arch = "x86_64")]
    while i + 1 < K {
        let (sp, cp) = sse2::pair([x[i], x[i + 1]]);
        [s[i], s[i + 1]] = sp;
        [c[i], c[i + 1]] = cp;
        i += 2;
    }
    while i < K {
        (s[i], c[i]) = lane(x[i]);
        i += 1;
    }
    // Far (or non-finite) lanes: libm, lane by lane.
    let mut far = false;
    for v in x {
        far |= !reduced_here(v);
    }
    if far {
        for i in 0..K {
            if !reduced_here(x[i]) {
                (s[i], c[i]) = x[i].sin_cos();
            }
        }
    }
    (s, c)
}

/// The scalar kernel on one lane (meaningful for `|x| < LIMIT`).
#[inline(always)]
fn lane(x: f64) -> (f64, f64) {
    // Reduction: k = round(x 2/pi) (n: its low bits), r = x - k pi/2.
    let t = x * std::f64::consts::FRAC_2_PI + SHIFT;
    let n = t.to_bits();
    let k = t - SHIFT;
    let r = ((x - k * P1) - k * P2) - k * P3;
    let z = r * r;
    // fdlibm's polynomials by Estrin's scheme (short dependency chains).
    let (z2, z4) = (z * z, (z * z) * (z * z));
    let ps = ((S[0] + z * S[1]) + z2 * (S[2] + z * S[3])) + z4 * (S[4] + z * S[5]);
    let pc = ((C[0] + z * C[1]) + z2 * (C[2] + z * C[3])) + z4 * (C[4] + z * C[5]);
    let sr = r + (z * r) * ps;
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    let cr = w + (((1.0 - w) - hz) + z2 * pc);
    // Quadrant k mod 4: odd k swaps sine and cosine; the sine is negated for k = 2, 3,
    // the cosine for k = 1, 2. Done on the bit patterns (no branch).
    let swap = (n & 1).wrapping_neg();
    let (sb, cb) = (sr.to_bits(), cr.to_bits());
    let sign_s = (n & 2) << 62;
    let sign_c = (n.wrapping_add(1) & 2) << 62;
    (
        f64::from_bits(((sb & !swap) | (cb & swap)) ^ sign_s),
        f64::from_bits(((cb & !swap) | (sb & swap)) ^ sign_c),
    )
}

/// The kernel of [`lane`] on two lanes in one SSE2 register, operation for operation.
///
/// SSE2 is part of the x86-64 baseline: the intrinsics are always available and, the
/// feature being statically enabled, safe to call (no `unsafe`: lanes go in with
/// `_mm_set_pd` and come out with `_mm_cvtsd_f64`).
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod sse2 {
    use super::{C, P1, P2, P3, S, SHIFT};
    use std::arch::x86_64::{
        __m128d, __m128i, _mm_add_epi64, _mm_add_pd, _mm_and_si128, _mm_andnot_si128,
        _mm_castpd_si128, _mm_castsi128_pd, _mm_cvtsd_f64, _mm_mul_pd, _mm_or_si128, _mm_set_pd,
        _mm_set1_epi64x, _mm_set1_pd, _mm_setzero_si128, _mm_slli_epi64, _mm_sub_epi64, _mm_sub_pd,
        _mm_unpackhi_pd, _mm_xor_si128,
    };

    #[inline(always)]
    fn add(a: __m128d, b: __m128d) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_add_pd(a, b) }
    }

    #[inline(always)]
    fn sub(a: __m128d, b: __m128d) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_sub_pd(a, b) }
    }

    #[inline(always)]
    fn mul(a: __m128d, b: __m128d) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_mul_pd(a, b) }
    }

    #[inline(always)]
    fn k1(v: f64) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_set1_pd(v) }
    }

    /// `c0 + z c1 + z2 (c2 + z c3) + z4 (c4 + z c5)` in [`super::lane`]'s order.
    #[inline(always)]
    fn poly(c: &[f64; 6], z: __m128d, z2: __m128d, z4: __m128d) -> __m128d {
        add(
            add(
                add(k1(c[0]), mul(z, k1(c[1]))),
                mul(z2, add(k1(c[2]), mul(z, k1(c[3])))),
            ),
            mul(z4, add(k1(c[4]), mul(z, k1(c[5])))),
        )
    }

    /// `(a & !mask) | (b & mask)`.
    #[inline(always)]
    fn pick(mask: __m128i, a: __m128i, b: __m128i) -> __m128i {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_or_si128(_mm_andnot_si128(mask, a), _mm_and_si128(b, mask)) }
    }

    /// Both lanes of a register.
    #[inline(always)]
    fn lanes(v: __m128d) -> [f64; 2] {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { [_mm_cvtsd_f64(v), _mm_cvtsd_f64(_mm_unpackhi_pd(v, v))] }
    }

    /// `(sin, cos)` of both lanes of `x` (meaningful for `|x| < LIMIT`).
    #[inline(always)]
    pub(super) fn pair(x: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        // SAFETY: SSE2 is in the x86-64 baseline; the intrinsics only compute on registers.
        unsafe {
            let xv = _mm_set_pd(x[1], x[0]);
            let t = add(mul(xv, k1(std::f64::consts::FRAC_2_PI)), k1(SHIFT));
            let n = _mm_castpd_si128(t);
            let k = sub(t, k1(SHIFT));
            let r = sub(sub(sub(xv, mul(k, k1(P1))), mul(k, k1(P2))), mul(k, k1(P3)));
            let z = mul(r, r);
            let (z2, z4) = (mul(z, z), mul(mul(z, z), mul(z, z)));
            let (ps, pc) = (poly(&S, z, z2, z4), poly(&C, z, z2, z4));
            let sr = add(r, mul(mul(z, r), ps));
            let hz = mul(k1(0.5), z);
            let w = sub(k1(1.0), hz);
            let cr = add(w, add(sub(sub(k1(1.0), w), hz), mul(z2, pc)));
            let one = _mm_set1_epi64x(1);
            let two = _mm_set1_epi64x(2);
            let swap = _mm_sub_epi64(_mm_setzero_si128(), _mm_and_si128(n, one));
            let (sb, cb) = (_mm_castpd_si128(sr), _mm_castpd_si128(cr));
            let sign_s = _mm_slli_epi64::<62>(_mm_and_si128(n, two));
            let sign_c = _mm_slli_epi64::<62>(_mm_and_si128(_mm_add_epi64(n, one), two));
            let s = _mm_xor_si128(pick(swap, sb, cb), sign_s);
            let c = _mm_xor_si128(pick(swap, cb, sb), sign_c);
            (lanes(_mm_castsi128_pd(s)), lanes(_mm_castsi128_pd(c)))
        }
    }
}

/// Whether `v` is reduced by the kernel (false for far and non-finite arguments).
#[inline(always)]
fn reduced_here(v: f64) -> bool {
    v.abs() < LIMIT
}

/// fdlibm's `__kernel_sin` coefficients S1..S6.
const S: [f64; 6] = [
    -1.666_666_666_666_663_243_48e-01,
    8.333_333_333_322_489_461_24e-03,
    -1.984_126_982_985_794_931_34e-04,
    2.755_731_370_707_006_767_89e-06,
    -2.505_076_025_340_686_341_95e-08,
    1.589_690_995_211_550_102_21e-10,
];
/// fdlibm's `__kernel_cos` coefficients C1..C6.
const C: [f64; 6] = [
    4.166_666_666_666_660_190_37e-02,
    -1.388_888_888_887_410_957_49e-03,
    2.480_158_728_947_672_941_78e-05,
    -2.755_731_435_139_066_330_35e-07,
    2.087_572_321_298_174_827_90e-09,
    -1.135_964_755_778_819_482_65e-11,
];

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between two finite doubles of the same sign
    /// (or both zero-ish).
    fn ulps(a: f64, b: f64) -> u64 {
        if a == b {
            return 0;
        }
        let key = |v: f64| {
            let b = v.to_bits() as i64;
            if b < 0 { i64::MIN - b } else { b }
        };
        key(a).abs_diff(key(b))
    }

    /// Worst distance to libm's `sin_cos` over seeded arguments uniform in `[-scale, scale]`.
    fn worst_ulps(scale: f64, samples: u64) -> u64 {
        let mut worst = 0;
        let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..samples {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            let x = (2.0 * u - 1.0) * scale;
            let ([s], [c]) = sin_cos([x]);
            let (s0, c0) = x.sin_cos();
            worst = worst.max(ulps(s, s0)).max(ulps(c, c0));
        }
        worst
    }

    #[test]
    fn within_one_ulp_of_libm_for_joint_angles_two_up_to_the_limit() {
        // Joint angles, a few hundred turns: 1 ulp.
        for scale in [4.0, 40.0, 1000.0] {
            assert!(worst_ulps(scale, 200_000) <= 1, "scale {scale}");
        }
        // Beyond, the two roundings of the reduction (no tail word is carried) show: 2 ulp.
        assert!(worst_ulps(LIMIT, 200_000) <= 2);
    }

    #[test]
    fn multiples_of_half_pi_and_special_values() {
        for k in -2000..=2000 {
            let x = f64::from(k) * std::f64::consts::FRAC_PI_2;
            let ([s], [c]) = sin_cos([x]);
            let (s0, c0) = x.sin_cos();
            // Near zeros the error is absolute (the reduction keeps ~1e-16 of r).
            assert!(
                (s - s0).abs() <= 1e-16 * (1.0 + x.abs() / 1e3),
                "sin {x}: {s} {s0}"
            );
            assert!(
                (c - c0).abs() <= 1e-16 * (1.0 + x.abs() / 1e3),
                "cos {x}: {c} {c0}"
            );
        }
        let ([s, t, u, v], [c, d, e, f]) = sin_cos([0.0, f64::NAN, f64::INFINITY, 1e300]);
        assert_eq!((s.to_bits(), c), (0.0f64.to_bits(), 1.0));
        assert!(t.is_nan() && d.is_nan() && u.is_nan() && e.is_nan());
        assert_eq!((v, f), 1e300f64.sin_cos());
    }

    #[test]
    fn every_lane_count_gives_the_same_values() {
        let xs = [
            0.3,
            -2.9,
            std::f64::consts::FRAC_PI_2,
            700.25,
            -3.0e4,
            1e-300,
            -0.0,
        ];
        let (s, c) = sin_cos(xs);
        for (i, &x) in xs.iter().enumerate() {
            let ([s1], [c1]) = sin_cos([x]);
            let ([_, s3, _], [_, c3, _]) = sin_cos([1.0, x, -5.0]);
            let bits = (s[i].to_bits(), c[i].to_bits());
            assert_eq!(bits, (s1.to_bits(), c1.to_bits()), "{x}");
            assert_eq!(bits, (s3.to_bits(), c3.to_bits()), "{x}");
        }
    }

    /// The SSE2 pairs and the scalar kernel give the same bits, lane by lane.
    #[test]
    fn pairs_and_single_lanes_agree_bit_for_bit() {
        let mut state: u64 = 0x0123_4567_89AB_CDEF;
        for k in 0..200_000u32 {
            let mut next = || {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                // Scales from 1e-3 to 1e5 (the kernel's range), both signs.
                (2.0 * u - 1.0) * 10f64.powi((k % 9) as i32 - 3)
            };
            let (a, b) = (next(), next());
            let (s, c) = sin_cos([a, b]);
            for (i, x) in [a, b].into_iter().enumerate() {
                let (s1, c1) = lane(x);
                assert_eq!(
                    (s[i].to_bits(), c[i].to_bits()),
                    (s1.to_bits(), c1.to_bits()),
                    "{x}"
                );
            }
        }
    }

    #[test]
    fn a_lane_does_not_depend_on_the_others() {
        let ([a, b], [c, d]) = sin_cos([0.7, 3e7]);
        let ([a1], [c1]) = sin_cos([0.7]);
        assert_eq!((a.to_bits(), c.to_bits()), (a1.to_bits(), c1.to_bits()));
        assert_eq!((b, d), 3e7f64.sin_cos());
    }
}
