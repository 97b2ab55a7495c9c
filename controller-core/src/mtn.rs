//! The multi-dimensional Taylor network regressor `Φ_m(X)` (the paper's Lemma 4, LAW §4).
//!
//! `Φ_m(X)` holds every monomial of `X ∈ R^d` of total degree `1..=m`, `C(d+m, m) − 1` entries.
//! The law needs only `‖Φ‖² = Σ_{k=1..m} h_k(X₁², …, X_d²)` (complete homogeneous symmetric
//! polynomials), which [`MtnAccumulator`] evaluates in `O(d·m)` without building `Φ`.

use crate::{error::ConfigError, param::Param};

pub use crate::param::MAX_MTN_ORDER;

/// `Φ` did not fit the caller's buffer.
///
/// ```
/// use controller_core::{mtn::CapacityError, MtnRegressor};
/// // d = 3 inputs, m = 2: C(5, 2) − 1 = 9 entries do not fit 8.
/// let e = MtnRegressor::new(2)?.phi::<8>(&[1.0, 2.0, 3.0]).unwrap_err();
/// assert_eq!(e, CapacityError { needed: 9 });
/// assert_eq!(e.to_string(), "the regressor has 9 entries, more than the buffer holds");
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CapacityError {
    /// Entries `Φ` has.
    pub needed: usize,
}

impl core::fmt::Display for CapacityError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "the regressor has {} entries, more than the buffer holds",
            self.needed
        )
    }
}

impl core::error::Error for CapacityError {}

/// The regressor of one MTN order `m` (Lemma 4).
///
/// ```
/// use controller_core::MtnRegressor;
/// // m = 2, X = (x_1, x_2) = (1, 2): Φ = (x_1, x_2, x_1², x_1 x_2, x_2²), C(4, 2) − 1 = 5 entries.
/// let mtn = MtnRegressor::new(2)?;
/// let phi = mtn.phi::<5>(&[1.0, 2.0]).unwrap();
/// assert_eq!(phi.as_slice(), &[1.0, 2.0, 1.0, 2.0, 4.0]);
/// // The law needs only ‖Φ‖² = 1 + 4 + 1 + 4 + 16, evaluated without building Φ.
/// assert_eq!(mtn.norm_sq(&[1.0, 2.0]), 26.0);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MtnRegressor {
    order: u8,
}

impl MtnRegressor {
    /// A regressor of order `1 ≤ m ≤ MAX_MTN_ORDER`.
    ///
    /// ```
    /// use controller_core::{mtn::MAX_MTN_ORDER, param::Param, MtnRegressor};
    /// assert_eq!(MtnRegressor::new(MAX_MTN_ORDER)?.order(), MAX_MTN_ORDER);
    /// assert_eq!(MtnRegressor::new(0).unwrap_err().param(), Param::MtnOrder);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    pub const fn new(order: usize) -> Result<Self, ConfigError> {
        match Param::MtnOrder.check_count(order) {
            Ok(order) => Ok(Self { order: order as u8 }),
            Err(e) => Err(e),
        }
    }

    /// The order `m`.
    ///
    /// ```
    /// use controller_core::{ControllerConfig, MtnRegressor};
    /// let cfg = ControllerConfig::<2>::default();
    /// assert_eq!(MtnRegressor::new(cfg.mtn_order)?.order(), 2); // the examples' order
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn order(&self) -> usize {
        self.order as usize
    }

    /// `dim Φ = C(d+m, m) − 1` for an input of dimension `d`.
    ///
    /// ```
    /// use controller_core::MtnRegressor;
    /// assert_eq!(MtnRegressor::new(2).unwrap().len(3), 9); // 3 linear + 6 quadratic
    /// // C(d+m, m) − 1 for d = 4 neighbours' and own outputs, m = 3: C(7, 3) − 1 = 34.
    /// assert_eq!(MtnRegressor::new(3).unwrap().len(4), 34);
    /// assert_eq!(MtnRegressor::new(5).unwrap().len(0), 0);
    /// ```
    #[must_use]
    pub const fn len(&self, d: usize) -> usize {
        // C(d+m, m) built incrementally: C(d+k, k) = C(d+k−1, k−1)·(d+k)/k, exact at every k.
        let mut c = 1usize;
        let mut k = 1;
        while k <= self.order as usize {
            c = c * (d + k) / k;
            k += 1;
        }
        c - 1
    }

    /// A streaming evaluator of `‖Φ‖²`: push the inputs one by one.
    ///
    /// ```
    /// use controller_core::MtnRegressor;
    /// // Step j of (18) uses X_j = (x_1, …, x_j): one accumulator serves every step.
    /// let mtn = MtnRegressor::new(2)?;
    /// let mut acc = mtn.accumulator();
    /// acc.push(1.0);
    /// assert_eq!(acc.norm_sq(), mtn.norm_sq(&[1.0])); // ‖Φ_1‖²
    /// acc.push(2.0);
    /// assert_eq!(acc.norm_sq(), mtn.norm_sq(&[1.0, 2.0])); // ‖Φ_2‖²
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[inline]
    #[must_use]
    pub const fn accumulator(&self) -> MtnAccumulator {
        MtnAccumulator {
            h1: 0.0,
            h2: 0.0,
            higher: [0.0; MAX_MTN_ORDER - 2],
            order: self.order,
        }
    }

    /// `‖Φ(x)‖²` of a whole input vector.
    ///
    /// ```
    /// use controller_core::MtnRegressor;
    /// // Against the built vector for m = 3, d = 3.
    /// let mtn = MtnRegressor::new(3)?;
    /// let x = [0.5, -1.5, 2.0];
    /// let phi = mtn.phi::<19>(&x).unwrap();
    /// let built: f32 = phi.iter().map(|v| v * v).sum();
    /// assert!((mtn.norm_sq(&x) - built).abs() < 1e-4 * built);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub fn norm_sq(&self, x: &[f32]) -> f32 {
        let mut acc = self.accumulator();
        for &v in x {
            acc.push(v);
        }
        acc.norm_sq()
    }

    /// The full vector `Φ(x)` (degree by degree, monomials in lexicographic order of their
    /// variable indices) into a fixed-capacity buffer: for inspection and tests, not the hot path.
    ///
    /// ```
    /// use controller_core::MtnRegressor;
    /// let phi = MtnRegressor::new(3)?.phi::<9>(&[2.0, 3.0]).unwrap();
    /// // Degree 1, 2, 3 in turn: x_1, x_2 | x_1², x_1x_2, x_2² | x_1³, x_1²x_2, x_1x_2², x_2³.
    /// assert_eq!(phi.as_slice(), &[2.0, 3.0, 4.0, 6.0, 9.0, 8.0, 12.0, 18.0, 27.0]);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    pub fn phi<const CAP: usize>(
        &self,
        x: &[f32],
    ) -> Result<heapless::Vec<f32, CAP>, CapacityError> {
        let needed = self.len(x.len());
        if needed > CAP {
            return Err(CapacityError { needed });
        }
        let mut out = heapless::Vec::new();
        if x.is_empty() {
            return Ok(out);
        }
        let d = x.len();
        for degree in 1..=self.order() {
            // Non-decreasing index tuples of length `degree`.
            let mut idx = [0usize; MAX_MTN_ORDER];
            loop {
                let value = idx
                    .iter()
                    .take(degree)
                    .fold(1.0f32, |p, &i| p * x.get(i).copied().unwrap_or(0.0));
                out.push(value).map_err(|_| CapacityError { needed })?;
                // Next non-decreasing tuple: bump the rightmost index that can still grow.
                let Some(pos) = (0..degree)
                    .rev()
                    .find(|&p| idx.get(p).is_some_and(|&i| i + 1 < d))
                else {
                    break;
                };
                let v = idx.get(pos).map_or(0, |&i| i + 1);
                for slot in idx.iter_mut().take(degree).skip(pos) {
                    *slot = v;
                }
            }
        }
        Ok(out)
    }
}

/// Running `h_k(z_1..z_j)`, `k = 1..=m`, of the squared inputs pushed so far: `h_1`, `h_2` as
/// scalars (all the examples' order 2 needs), `h_3..h_m` in a short array.
///
/// ```
/// use controller_core::MtnRegressor;
/// let mut acc = MtnRegressor::new(2)?.accumulator();
/// for x in [1.0, 2.0, 3.0] {
///     acc.push(x);
/// }
/// // h_1(1, 4, 9) = 14, h_2(1, 4, 9) = 1 + 16 + 81 + 4 + 9 + 36 = 147.
/// assert_eq!(acc.norm_sq(), 14.0 + 147.0);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MtnAccumulator {
    h1: f32,
    h2: f32,
    higher: [f32; MAX_MTN_ORDER - 2],
    order: u8,
}

impl MtnAccumulator {
    /// Add one input `x`: `h_k ← h_k + x² h_{k−1}` for rising `k` (`h_0 = 1`).
    ///
    /// ```
    /// use controller_core::MtnRegressor;
    /// let mut acc = MtnRegressor::new(1)?.accumulator();
    /// acc.push(3.0);
    /// acc.push(-4.0);
    /// assert_eq!(acc.norm_sq(), 25.0); // m = 1: Φ = X, ‖Φ‖² = ‖X‖²
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[inline]
    pub fn push(&mut self, x: f32) {
        let z = x * x;
        self.h1 += z;
        if self.order >= 2 {
            self.h2 += z * self.h1;
            if self.order > 2 {
                self.push_higher(z);
            }
        }
    }

    /// `h_3..h_m` of [`Self::push`]: out of line, so that the step's loops over the order-2
    /// examples stay small enough to be unrolled.
    #[inline(never)]
    fn push_higher(&mut self, z: f32) {
        let mut prev = self.h2;
        for hk in self.higher.iter_mut().take(self.order as usize - 2) {
            *hk += z * prev;
            prev = *hk;
        }
    }

    /// `‖Φ‖² = Σ_{k=1..m} h_k` of the inputs pushed so far (summed in rising `k`).
    ///
    /// ```
    /// use controller_core::MtnRegressor;
    /// let acc = MtnRegressor::new(4)?.accumulator();
    /// assert_eq!(acc.norm_sq(), 0.0); // nothing pushed: Φ has no constant term
    /// let mut acc = acc;
    /// acc.push(2.0);
    /// assert_eq!(acc.norm_sq(), 4.0 + 16.0 + 64.0 + 256.0); // x², x⁴, x⁶, x⁸
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[inline]
    #[must_use]
    pub fn norm_sq(&self) -> f32 {
        match self.order {
            1 => self.h1,
            2 => self.h1 + self.h2,
            _ => self.norm_sq_higher(),
        }
    }

    /// [`Self::norm_sq`] for `m ≥ 3` (out of line, as [`Self::push_higher`]).
    #[inline(never)]
    fn norm_sq_higher(&self) -> f32 {
        self.higher
            .iter()
            .take(self.order as usize - 2)
            .fold(self.h1 + self.h2, |acc, &h| acc + h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute_norm_sq(order: usize, x: &[f32]) -> f64 {
        let phi: heapless::Vec<f32, 512> = MtnRegressor::new(order).unwrap().phi(x).unwrap();
        phi.iter().map(|&v| (v as f64) * (v as f64)).sum()
    }

    #[test]
    fn recurrence_equals_sum_of_squares_of_phi() {
        let xs: [&[f32]; 5] = [
            &[0.3],
            &[0.5, -1.2],
            &[0.1, 0.7, -0.4],
            &[1.1, -0.2, 0.3, 0.9],
            &[0.2, 0.4, -0.6, 0.8, -1.0],
        ];
        for order in 1..=4 {
            for x in xs {
                let r = MtnRegressor::new(order).unwrap();
                let fast = r.norm_sq(x) as f64;
                let slow = brute_norm_sq(order, x);
                assert!(
                    (fast - slow).abs() <= 1e-5 * slow.max(1.0),
                    "order {order} x {x:?}: {fast} vs {slow}"
                );
                let phi: heapless::Vec<f32, 512> = r.phi(x).unwrap();
                assert_eq!(phi.len(), r.len(x.len()));
            }
        }
    }

    #[test]
    fn written_out_orders_equal_the_loop_bit_for_bit() {
        for order in 1..=5u8 {
            let mut fast = MtnRegressor::new(order as usize)
                .map(|r| r.accumulator())
                .expect("valid order");
            let mut h = [0.0f32; MAX_MTN_ORDER + 1];
            for &x in &[0.37f32, -1.9, 1e-3, 42.0, -0.5] {
                fast.push(x);
                let z = x * x;
                let mut prev = 1.0;
                for hk in h.iter_mut().take(order as usize + 1).skip(1) {
                    *hk += z * prev;
                    prev = *hk;
                }
                let slow: f32 = h.iter().take(order as usize + 1).skip(1).sum();
                assert_eq!(fast.norm_sq().to_bits(), slow.to_bits(), "order {order}");
            }
        }
    }

    #[test]
    fn phi_by_hand() {
        let r = MtnRegressor::new(2).unwrap();
        let phi: heapless::Vec<f32, 16> = r.phi(&[2.0, 3.0]).unwrap();
        assert_eq!(phi.as_slice(), &[2.0, 3.0, 4.0, 6.0, 9.0]);
        assert_eq!(r.norm_sq(&[2.0, 3.0]), 4.0 + 9.0 + 16.0 + 36.0 + 81.0);
        let small: Result<heapless::Vec<f32, 4>, _> = r.phi(&[2.0, 3.0]);
        assert_eq!(small, Err(CapacityError { needed: 5 }));
    }

    #[test]
    fn dimension_is_binomial() {
        assert_eq!(MtnRegressor::new(1).unwrap().len(4), 4);
        assert_eq!(MtnRegressor::new(3).unwrap().len(2), 9);
        assert_eq!(MtnRegressor::new(2).unwrap().len(0), 0);
        let out_of_range = Err(ConfigError::new(
            Param::MtnOrder,
            crate::param::Reason::OutOfRange,
        ));
        assert_eq!(MtnRegressor::new(0), out_of_range);
        assert_eq!(MtnRegressor::new(9), out_of_range);
    }
}
