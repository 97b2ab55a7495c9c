//! LAW §8 Example 1: `ẋ_1 = x_2 + 0.8 x_1³`, `ẋ_2 = a_1 + a_2 − 2 x_1² + x_2³ + cos t`.

use super::{Lanes, Plant};

/// The paper's numerical Example 1 (n = 2, m = 2).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Example1;

impl Plant<2, 2> for Example1 {
    /// The disturbance `cos t`.
    type Time = f64;

    #[inline]
    fn at(&self, t: f64) -> f64 {
        t.cos()
    }

    #[inline]
    fn derivative(&self, cos_t: &f64, x: &[f64; 2], a: &[f64; 2]) -> [f64; 2] {
        [
            x[1] + 0.8 * x[0] * x[0] * x[0],
            a[0] + a[1] - 2.0 * x[0] * x[0] + x[1] * x[1] * x[1] + cos_t,
        ]
    }

    /// The expressions of `derivative`, lane by lane.
    #[inline]
    fn derivative_lanes<const B: usize>(
        &self,
        cos_t: &f64,
        x: &Lanes<2, B>,
        a: &Lanes<2, B>,
    ) -> Lanes<2, B> {
        let ([x0, x1], [a0, a1]) = (x, a);
        [
            std::array::from_fn(|b| x1[b] + 0.8 * x0[b] * x0[b] * x0[b]),
            std::array::from_fn(|b| {
                a0[b] + a1[b] - 2.0 * x0[b] * x0[b] + x1[b] * x1[b] * x1[b] + cos_t
            }),
        ]
    }
}
