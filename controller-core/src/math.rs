//! The one math shim: every transcendental call of the crate goes through here, so the rest of the
//! code never sees whether `libm` (default, accurate) or `micromath` (faster approximations)
//! is behind it. With both features on, `micromath` wins.
//!
//! The per-step functions ([`pow_pos`], [`sqrt`], [`tanh`]) are organised for a Cortex-M4F,
//! where the FPU has `vsqrt`/`vdiv` but no `exp`/`log` and `core` exposes no `f32::sqrt` in
//! `no_std`: with `libm` they are this module's own kernels, accurate to a few ulp (see the
//! tests), built on one `ln` and one `exp` with short polynomials:
//!
//! * `x^y = e^(y ln x)` instead of `libm::powf` (≈ 100 instead of ≈ 200 instructions; `powf`'s
//!   extra-precise logarithm buys nothing for the small exponents `ζ`, `1 ± ζ` of the law);
//! * `√x` by two Newton steps on `1/√x` from the bit-level estimate and one correction
//!   (libm's `sqrtf` is an integer software routine);
//! * `tanh x = 1 − 2/(e^(2x) + 1)`, an odd polynomial near 0.
//!
//! The configuration-time functions ([`powf`], [`exp`], [`ln`]) stay on `libm`.

#[cfg(not(any(feature = "libm", feature = "micromath")))]
compile_error!(
    "controller-core needs a math backend: enable the `libm` (default) or `micromath` feature"
);

// The per-step functions call it as `F32Ext::f(x)`: in test builds (with `std`) `x.f()` picks
// `std`'s inherent method, so their tests would not see `micromath` (the configuration-time
// `powf`, `exp`, `ln` keep the method form, and so `std`'s accuracy, in tests).
#[cfg(feature = "micromath")]
use micromath::F32Ext;

#[cfg(test)]
std::thread_local! {
    /// Test builds only: route the per-step functions to `libm`'s `powf`, `sqrtf`, `tanhf` on
    /// this thread (the "exact-math run" the closed-loop comparison measures against).
    static EXACT: core::cell::Cell<bool> = const { core::cell::Cell::new(false) };
}

/// Test builds only: runs `f` with the per-step functions on `libm` (see [`EXACT`]).
#[cfg(test)]
pub(crate) fn with_exact_math<T>(f: impl FnOnce() -> T) -> T {
    EXACT.with(|e| e.set(true));
    let r = f();
    EXACT.with(|e| e.set(false));
    r
}

#[cfg(test)]
fn exact() -> bool {
    EXACT.with(core::cell::Cell::get)
}

/// `x^y` for `x ≥ 0`.
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        x.powf(y)
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::powf(x, y)
    }
}

/// `x^y` for `x > 0` and a moderate `y` (the law's `ζ`, `κ`): `e^(y ln x)`, the per-step power.
/// With `libm` the relative error is within `(2 + |y ln x|)` ulp (≤ 4 ulp for `|e|^ζ` over the
/// range of the examples). `x = 0` gives 0 for `y > 0`, `x < 0` or NaN gives NaN, `x = ∞`
/// gives `∞` for `y > 0`.
#[inline]
pub fn pow_pos(x: f32, y: f32) -> f32 {
    #[cfg(test)]
    if exact() {
        return libm::powf(x, y);
    }
    #[cfg(feature = "micromath")]
    {
        F32Ext::powf(x, y)
    }
    #[cfg(not(feature = "micromath"))]
    {
        kernel::exp(y * kernel::ln(x))
    }
}

/// `√x` for `x ≥ 0` (NaN for `x < 0`).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(test)]
    if exact() {
        return libm::sqrtf(x);
    }
    #[cfg(feature = "micromath")]
    {
        F32Ext::sqrt(x)
    }
    #[cfg(not(feature = "micromath"))]
    {
        kernel::sqrt(x)
    }
}

/// `eˣ`.
#[inline]
pub fn exp(x: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        x.exp()
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::expf(x)
    }
}

/// Natural logarithm.
#[inline]
pub fn ln(x: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        x.ln()
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::logf(x)
    }
}

/// Hyperbolic tangent; `micromath` has none, so it is built from one `exp` there.
#[inline]
pub fn tanh(x: f32) -> f32 {
    #[cfg(test)]
    if exact() {
        return libm::tanhf(x);
    }
    #[cfg(feature = "micromath")]
    {
        let a = abs(x);
        if a > 9.0 {
            return sign(x);
        }
        let t = 1.0 - 2.0 / (exp(2.0 * a) + 1.0);
        t.copysign(x)
    }
    #[cfg(not(feature = "micromath"))]
    {
        kernel::tanh(x)
    }
}

/// `|x|`.
#[inline]
pub fn abs(x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0x7fff_ffff)
}

/// `sign(x)` with `sign(0) = 0` (the paper's convention), NaN for NaN.
#[inline]
pub fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        x * 0.0
    }
}

/// `x^k` for a non-negative integer `k`, by squaring (`O(log k)` products).
#[inline]
pub fn powi(mut x: f32, mut k: u32) -> f32 {
    let mut acc = 1.0;
    while k > 0 {
        if k & 1 == 1 {
            acc *= x;
        }
        x *= x;
        k >>= 1;
    }
    acc
}

/// The accurate per-step kernels of the `libm` build (no table, no integer software routine).
#[cfg(any(test, not(feature = "micromath")))]
mod kernel {
    use core::f32::consts::{LOG2_E, SQRT_2};

    /// `ln 2` split so that `n · LN2_HI` is exact for `|n| < 2^11`.
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;

    /// Natural logarithm: `x = 2^e m`, `m ∈ [√½, √2)`, `ln m = 2 atanh(s)`, `s = (m−1)/(m+1)`,
    /// `|s| ≤ 0.172`, series to `s⁹` (truncation < 3e-9 relative).
    #[inline]
    pub fn ln(x: f32) -> f32 {
        if x.is_nan() || x <= 0.0 {
            return if x == 0.0 {
                f32::NEG_INFINITY
            } else {
                f32::NAN
            };
        }
        if x == f32::INFINITY {
            return x;
        }
        let mut bits = x.to_bits();
        let mut e: i32 = -127;
        if bits < 0x0080_0000 {
            // Subnormal: scale by 2^24 first.
            bits = (x * 16_777_216.0).to_bits();
            e -= 24;
        }
        e += (bits >> 23) as i32;
        let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
        if m > SQRT_2 {
            m *= 0.5;
            e += 1;
        }
        let s = (m - 1.0) / (m + 1.0);
        let z = s * s;
        let tail = z * (1.0 / 3.0 + z * (1.0 / 5.0 + z * (1.0 / 7.0 + z * (1.0 / 9.0))));
        let ef = e as f32;
        ef * LN2_HI + (2.0 * s + (2.0 * s * tail + ef * LN2_LO))
    }

    /// `e^y`: `y = n ln 2 + r`, `|r| ≤ ln2/2`, Taylor to `r⁷` (truncation < 6e-9 relative),
    /// scaled by `2^n` through the exponent bits (also into the subnormal range).
    #[inline]
    pub fn exp(y: f32) -> f32 {
        if y > 88.722_84 {
            return f32::INFINITY;
        }
        if y < -103.972_08 {
            return 0.0;
        }
        let t = y * LOG2_E;
        // Round to nearest (the conversion truncates toward zero). NaN converts to 0 and
        // propagates through `r`.
        let n = (t + if t >= 0.0 { 0.5 } else { -0.5 }) as i32;
        let nf = n as f32;
        let r = (y - nf * LN2_HI) - nf * LN2_LO;
        let p = 1.0
            + r * (1.0
                + r * (0.5
                    + r * (1.0 / 6.0
                        + r * (1.0 / 24.0
                            + r * (1.0 / 120.0 + r * (1.0 / 720.0 + r * (1.0 / 5040.0)))))));
        if n >= -126 {
            // n ≤ 128 here; 2^128 is split in two factors.
            if n > 127 {
                p * 2.0 * f32::from_bits(((n - 1 + 127) as u32) << 23)
            } else {
                p * f32::from_bits(((n + 127) as u32) << 23)
            }
        } else {
            p * f32::from_bits(((n + 127 + 64) as u32) << 23) * f32::from_bits(63 << 23)
        }
    }

    /// `√x`: two Newton steps on `1/√x` from the bit-level estimate (relative error ≤ 5e-6),
    /// then one Newton correction of `x · (1/√x)`.
    #[inline]
    pub fn sqrt(x: f32) -> f32 {
        if !(x > 0.0 && x < f32::INFINITY) {
            // 0, ∞, NaN; negative → NaN.
            return if x >= 0.0 { x } else { f32::NAN };
        }
        let (xs, k) = if x < 1.0e-30 {
            // Subnormal-safe: scale by 2^64, the root by 2^-32.
            (x * 18_446_744_073_709_551_616.0, 2.328_306_4e-10)
        } else {
            (x, 1.0)
        };
        let h = 0.5 * xs;
        let mut y = f32::from_bits(0x5f37_5a86 - (xs.to_bits() >> 1));
        y *= 1.5 - h * y * y;
        y *= 1.5 - h * y * y;
        let s = xs * y;
        (s + (xs - s * s) * (0.5 * y)) * k
    }

    /// `tanh x`: odd Taylor polynomial to `x¹¹` for `|x| < 0.3`, `1 − 2/(e^(2|x|) + 1)` up to
    /// `|x| < 9`, then ±1 (exact in `f32`).
    #[inline]
    pub fn tanh(x: f32) -> f32 {
        let a = super::abs(x);
        let t = if a < 0.3 {
            let z = a * a;
            a + a
                * z
                * (-1.0 / 3.0
                    + z * (2.0 / 15.0
                        + z * (-17.0 / 315.0 + z * (62.0 / 2835.0 + z * (-1382.0 / 155_925.0)))))
        } else if a < 9.0 {
            1.0 - 2.0 / (exp(2.0 * a) + 1.0)
        } else if a >= 9.0 {
            1.0
        } else {
            return x; // NaN
        };
        t.copysign(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative error in units of f32 epsilon, against an f64 reference.
    fn ulps(got: f32, want: f64) -> f64 {
        if want == 0.0 {
            return (got as f64).abs() / f64::from(f32::MIN_POSITIVE);
        }
        ((got as f64 - want) / want).abs() / f64::from(f32::EPSILON)
    }

    /// Log-spaced sweep over `[lo, hi]`.
    fn sweep(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f32> {
        (0..=n).map(move |k| (lo.ln() + (hi / lo).ln() * k as f64 / n as f64).exp() as f32)
    }

    #[test]
    fn kernel_ln_exp_pow_are_accurate() {
        let mut worst = (0.0f64, 0.0f64, 0.0f64);
        for x in sweep(1e-44, 3e38, 200_000) {
            let l = kernel::ln(x);
            let want = f64::from(x).ln();
            // Absolute error near ln x = 0, relative elsewhere.
            let err = (l as f64 - want).abs() / (f64::from(f32::EPSILON) * want.abs().max(1.0));
            worst.0 = worst.0.max(err);
            for y in [0.1f32, 0.9, 1.1, 1.2, 2.0] {
                let want = f64::from(x).powf(f64::from(y));
                if want < 1e37 && want > 1e-37 {
                    // Rounding y·ln x costs |y ln x| ulp of the result: measure beyond it.
                    let err = ulps(kernel::exp(y * kernel::ln(x)), want);
                    worst.2 = worst.2.max(err / (2.0 + (want.ln()).abs()));
                }
            }
        }
        for k in -1_000_000..=1_000_000 {
            let y = k as f32 * 8.8e-5;
            worst.1 = worst.1.max(ulps(kernel::exp(y), f64::from(y).exp()));
        }
        assert!(worst.0 < 2.0, "ln: {} eps", worst.0);
        assert!(worst.1 < 2.0, "exp: {} ulp", worst.1);
        // x^y = e^(y ln x): the error grows with |y ln x| (rounding of the product).
        assert!(worst.2 < 1.5, "pow: {} ulp per (2 + |y ln x|)", worst.2);
        assert_eq!(kernel::exp(100.0), f32::INFINITY);
        assert_eq!(kernel::exp(-200.0), 0.0);
        assert!(kernel::exp(-100.0) > 0.0 && kernel::exp(-100.0) < 1e-43);
        assert_eq!(kernel::ln(f32::INFINITY), f32::INFINITY);
        assert!(kernel::ln(-1.0).is_nan() && kernel::ln(f32::NAN).is_nan());
        assert!(kernel::exp(f32::NAN).is_nan());
    }

    #[test]
    fn kernel_pow_small_exponent_is_near_libm() {
        // The law's powers: |e|^ζ with ζ = 0.1, 0.6 where errors and estimates live
        // (|ζ ln x| ≤ 2.8): within 4 ulp of the exact value.
        for zeta in [0.1f32, 0.6] {
            for x in sweep(1e-2, 1e2, 100_000) {
                let want = f64::from(x).powf(f64::from(zeta));
                let got = kernel::exp(zeta * kernel::ln(x));
                assert!(ulps(got, want) < 4.0, "{x}^{zeta}: {got} vs {want}");
            }
        }
        for x in sweep(1e-6, 1e6, 100_000) {
            let want = f64::from(x).powf(0.1);
            let got = kernel::exp(0.1 * kernel::ln(x));
            assert!(ulps(got, want) < 4.0, "{x}^0.1: {got} vs {want}");
        }
    }

    #[test]
    fn kernel_sqrt_is_accurate() {
        let mut worst = 0.0f64;
        // Every f32 in [1, 4) (covers every exponent parity), then a wide log sweep.
        let mut b = 1.0f32.to_bits();
        while b < 4.0f32.to_bits() {
            let x = f32::from_bits(b);
            worst = worst.max(ulps(kernel::sqrt(x), f64::from(x).sqrt()));
            b += 1;
        }
        for x in sweep(1e-45, 3.4e38, 200_000) {
            worst = worst.max(ulps(kernel::sqrt(x), f64::from(x).sqrt()));
        }
        assert!(worst <= 1.0, "sqrt: {worst} ulp");
        assert_eq!(kernel::sqrt(0.0), 0.0);
        assert_eq!(kernel::sqrt(f32::INFINITY), f32::INFINITY);
        assert!(kernel::sqrt(-1.0).is_nan() && kernel::sqrt(f32::NAN).is_nan());
    }

    #[test]
    fn kernel_tanh_is_accurate() {
        let mut worst = 0.0f64;
        for k in -200_000..=200_000 {
            let x = k as f32 * 1e-4;
            worst = worst.max(ulps(kernel::tanh(x), f64::from(x).tanh()));
        }
        for x in sweep(1e-30, 1e-2, 10_000) {
            worst = worst.max(ulps(kernel::tanh(x), f64::from(x).tanh()));
        }
        assert!(worst < 4.0, "tanh: {worst} ulp");
        assert_eq!(kernel::tanh(50.0), 1.0);
        assert_eq!(kernel::tanh(-0.0).to_bits(), (-0.0f32).to_bits());
        assert!(kernel::tanh(f32::NAN).is_nan());
    }

    #[test]
    fn sign_convention() {
        assert_eq!(sign(2.0), 1.0);
        assert_eq!(sign(-0.5), -1.0);
        assert_eq!(sign(0.0), 0.0);
        assert_eq!(sign(-0.0), 0.0);
        assert!(sign(f32::NAN).is_nan());
    }

    #[test]
    fn powi_matches_repeated_product() {
        assert_eq!(powi(1.5, 0), 1.0);
        assert_eq!(powi(2.0, 10), 1024.0);
        let r = powi(1.0 / 0.9, 7);
        assert!((r - (1.0f64 / 0.9).powi(7) as f32).abs() < 1e-5);
    }

    #[test]
    fn tanh_saturates_and_is_odd() {
        assert!((tanh(20.0) - 1.0).abs() < 1e-6);
        assert!((tanh(-0.5) + tanh(0.5)).abs() < 1e-6);
        assert!((tanh(0.5) - 0.462_117_16).abs() < 2e-3);
    }
}
