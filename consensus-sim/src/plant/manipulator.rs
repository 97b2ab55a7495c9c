//! LAW §8 Example 2: single-link manipulator `ẋ_1 = x_2`, `M ẋ_2 = a_1 + a_2 − ½ m g l sin x_1`.

use super::Plant;

/// A single-link manipulator (n = 2, m = 2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Manipulator {
    /// Inertia `M`.
    pub inertia: f64,
    /// Mass `m`.
    pub mass: f64,
    /// Gravity `g`.
    pub gravity: f64,
    /// Link length `l`.
    pub length: f64,
}

impl Default for Manipulator {
    fn default() -> Self {
        Self {
            inertia: 1.0,
            mass: 1.0,
            gravity: 10.0,
            length: 1.0,
        }
    }
}

impl Plant<2, 2> for Manipulator {
    type Time = ();

    #[inline]
    fn at(&self, _t: f64) {}

    #[inline]
    fn derivative(&self, _t: &(), x: &[f64; 2], a: &[f64; 2]) -> [f64; 2] {
        let torque = a[0] + a[1] - 0.5 * self.mass * self.gravity * self.length * x[0].sin();
        [x[1], torque / self.inertia]
    }
}
