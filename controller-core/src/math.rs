//! The one math shim: every transcendental call of the crate goes through here, so the rest of the
//! code never sees whether `libm` (default, IEEE-accurate) or `micromath` (faster approximations)
//! is behind it. With both features on, `micromath` wins.

#[cfg(not(any(feature = "libm", feature = "micromath")))]
compile_error!(
    "controller-core needs a math backend: enable the `libm` (default) or `micromath` feature"
);

#[cfg(feature = "micromath")]
use micromath::F32Ext as _;

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

/// `√x` for `x ≥ 0`.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        x.sqrt()
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::sqrtf(x)
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
        libm::tanhf(x)
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

#[cfg(test)]
mod tests {
    use super::*;

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
