//! The hysteresis quantizer of the paper's eq. (2) with the sector property of Lemma 3
//! (`q = P u + R`, `1−δ ≤ P ≤ 1+δ`, `|R| ≤ u_min`), LAW §4.
//!
//! Levels are `u_c = u_min ρ^(1−c)`, `c = 1, 2, …`. With `a = |u_k|` and the direction
//! `d = sign(u_k − u_{k−1})`, the bracket `u_c < b ≤ u_{c+1}` is searched with `b = a` when
//! `d > 0` and `b = a (1+δ)` when `d < 0` (the two cases of eq. (2) written with one variable).
//! The search moves from the previous level (levels move little between samples) and falls
//! back to the closed form `c = ⌈ln(b/u_min) / ln(1/ρ)⌉` for large jumps, so a step costs no
//! logarithm in the common case and a bounded amount of work in every case (the closed form is
//! settled on the level values by galloping and bisection: O(log) level evaluations however far
//! the rounded estimate is off, as it is for `ρ` next to 1).
//!
//! Eq. (2) has infinitely many levels, `f32` has finitely many: the levels stop at the last one
//! that [`HysteresisQuantizer::level`] computes as a finite `f32` (its power `(1/ρ)^(c−1)` must
//! be finite too, so the top level is about `ρ min(1, u_min) f32::MAX` or more: 3.5e36 for the
//! paper's `ρ = 0.9`, `u_min = 0.01`), and the output saturates at the largest finite output
//! [`HysteresisQuantizer::saturation`] (`u_c` or `u_c (1+δ)` of that top level). So every finite
//! `u` gives a finite `q`; Lemma 3's sector holds for `|u|` up to the top level.

use crate::{
    error::ConfigError,
    math,
    param::{Param, Range, Reason},
};

/// How the direction `d` of eq. (2) is read.
///
/// ```
/// use controller_core::{HysteresisQuantizer, QuantizerConfig, QuantizerDirection};
/// let cfg = |direction| QuantizerConfig { rho: 0.5, u_min: 1.0, direction };
/// let signed = HysteresisQuantizer::new(&cfg(QuantizerDirection::Signed))?;
/// let magnitude = HysteresisQuantizer::new(&cfg(QuantizerDirection::Magnitude))?;
/// // u goes −1.8 → −1.2: u rises (d > 0) but |u| falls.
/// let (mut a, mut b) = (signed.state(), magnitude.state());
/// for u in [-1.8, -1.2] {
///     signed.quantize(&mut a, u);
///     magnitude.quantize(&mut b, u);
/// }
/// // Signed reads "rising" thresholds: |q| = u_1 = 1; magnitude keeps u_1 (1+δ) = 4/3.
/// assert_eq!(a.prev_q, -1.0);
/// assert!((b.prev_q + 4.0 / 3.0).abs() < 1e-6);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum QuantizerDirection {
    /// `d = sign(u_k − u_{k−1})`: the literal reading of eq. (2) (default).
    #[default]
    Signed,
    /// `d = sign(|u_k| − |u_{k−1}|)`: the odd-symmetric reading (also satisfies Lemma 3).
    Magnitude,
}

/// Quantizer parameters as a user writes them.
///
/// ```
/// use controller_core::{param::Param, HysteresisQuantizer, QuantizerConfig};
/// let paper = QuantizerConfig::default(); // ρ = 0.9, u_min = 0.01 (LAW §8)
/// assert_eq!((paper.rho, paper.u_min), (0.9, 0.01));
/// let bad = QuantizerConfig { rho: 1.0, ..paper }; // eq. (2) needs 0 < ρ < 1
/// assert_eq!(HysteresisQuantizer::new(&bad).unwrap_err().param(), Param::Rho);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct QuantizerConfig {
    /// `0 < ρ < 1`: ratio of successive levels.
    pub rho: f32,
    /// `u_min > 0`: the smallest non-zero level (dead zone).
    pub u_min: f32,
    /// Reading of the direction `d`.
    pub direction: QuantizerDirection,
}

impl Default for QuantizerConfig {
    fn default() -> Self {
        Self {
            rho: const { Param::Rho.default_f32() },
            u_min: const { Param::UMin.default_f32() },
            direction: QuantizerDirection::Signed,
        }
    }
}

/// Validated settings of the hysteresis quantizer (eq. 2).
///
/// With `ρ = 0.5`, `u_min = 1` the levels are `u_c = 1, 2, 4, …` and `δ = 1/3`. The output
/// at `u = 0.9` depends on where `u` came from: 0 on the way up (`a ≤ u_min`), `u_1 = 1` on
/// the way down (`a > u_min/(1+δ) = 0.75`). That band is the hysteresis that saves
/// transmissions.
///
/// ```
/// use controller_core::{HysteresisQuantizer, QuantizerConfig};
/// let q = HysteresisQuantizer::new(&QuantizerConfig { rho: 0.5, u_min: 1.0, ..Default::default() })?;
/// let mut s = q.state();
/// let up: Vec<f32> = [0.9, 1.2, 1.8, 2.5].iter().map(|&u| q.quantize(&mut s, u)).collect();
/// let down: Vec<f32> = [1.2, 0.9, 0.7].iter().map(|&u| q.quantize(&mut s, u)).collect();
/// let close = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
/// // Rising: 0 up to u_min, u_c while a ≤ u_c/(1−δ), then u_c (1+δ).
/// assert!(close(&up, &[0.0, 1.0, 4.0 / 3.0, 2.0]));
/// // Falling: u_c (1+δ) while a > u_c, u_c down to u_c/(1+δ), then the level below.
/// assert!(close(&down, &[4.0 / 3.0, 1.0, 0.0]));
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HysteresisQuantizer {
    u_min: f32,
    inv_rho: f32,
    delta: f32,
    one_plus_delta: f32,
    inv_one_minus_delta: f32,
    inv_ln_inv_rho: f32,
    ln_u_min: f32,
    max_index: u32,
    saturation: f32,
    direction: QuantizerDirection,
    /// `(1/ρ)^(2^i)`, `i < SQUARINGS`, formed by repeated squaring as [`math::powi`] forms them.
    squarings: [f32; SQUARINGS],
}

/// Per-actuator memory: the previous command and output, and the current level bracket.
///
/// ```
/// use controller_core::{HysteresisQuantizer, QuantizerConfig};
/// let q = HysteresisQuantizer::new(&QuantizerConfig::default())?;
/// let mut s = q.state();
/// let out = q.quantize(&mut s, 0.05);
/// assert_eq!((s.prev_u, s.prev_q), (0.05, out));
/// // The same command again (d = 0): the output is held.
/// assert_eq!(q.quantize(&mut s, 0.05), out);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct QuantizerState {
    /// `u_{k−1}`.
    pub prev_u: f32,
    /// `q_{k−1}`.
    pub prev_q: f32,
    index: u32,
    lower: f32,
    upper: f32,
}

impl Default for QuantizerState {
    /// A placeholder for controllers without a quantizer; [`HysteresisQuantizer::state`] gives
    /// the real initial state (from this one the first quantization locates the level by the
    /// closed form).
    fn default() -> Self {
        Self {
            prev_u: 0.0,
            prev_q: 0.0,
            index: 0,
            lower: 0.0,
            upper: 0.0,
        }
    }
}

/// Level changes walked one by one before the closed form is used instead.
const MAX_WALK: usize = 4;
/// `squarings[FAR]` is `(1/ρ)^MAX_WALK`: a `b` that far beyond the bracket goes to the closed
/// form without walking.
const FAR: usize = 2;
const _: () = assert!(1 << FAR == MAX_WALK);

/// Squarings of `1/ρ` kept by the quantizer: level powers below `2^SQUARINGS` (up to
/// `u_min ρ^−255`, 3.1e9 for the paper's `ρ`, `u_min`) take one product per set bit.
const SQUARINGS: usize = 8;

impl HysteresisQuantizer {
    /// Checks `0 < ρ < 1`, `u_min > 0`.
    ///
    /// ```
    /// use controller_core::{param::Param, HysteresisQuantizer, QuantizerConfig, Reason};
    /// let cfg = QuantizerConfig { u_min: -0.01, ..Default::default() };
    /// let e = HysteresisQuantizer::new(&cfg).unwrap_err();
    /// assert_eq!((e.param(), e.reason()), (Param::UMin, Reason::NonPositive));
    /// assert!(HysteresisQuantizer::new(&QuantizerConfig::default()).is_ok());
    /// ```
    pub fn new(cfg: &QuantizerConfig) -> Result<Self, ConfigError> {
        Param::Rho.check(cfg.rho)?;
        Param::UMin.check(cfg.u_min)?;
        let delta = (1.0 - cfg.rho) / (1.0 + cfg.rho);
        let inv_rho = 1.0 / cfg.rho;
        let inv_ln_inv_rho = Range::Positive
            .check(1.0 / math::ln(inv_rho))
            .map_err(|_| ConfigError::new(Param::Rho, Reason::DerivedOverflow))?;
        let ln_u_min = math::ln(cfg.u_min);
        let mut squarings = [inv_rho; SQUARINGS];
        let mut x = inv_rho;
        for sq in &mut squarings {
            *sq = x;
            x *= x;
        }
        let mut q = Self {
            u_min: cfg.u_min,
            inv_rho,
            delta,
            one_plus_delta: 1.0 + delta,
            inv_one_minus_delta: 1.0 / (1.0 - delta),
            inv_ln_inv_rho,
            ln_u_min,
            max_index: u32::MAX,
            saturation: f32::MAX,
            direction: cfg.direction,
            squarings,
        };
        // The first index whose level is no longer a finite f32 (the search never goes past
        // it), found by bisection on the levels as `level` computes them: `level(1) = u_min` is
        // finite and `level(u32::MAX) = u_min (1/ρ)^(2³²−2)` is not, as `1/ρ ≥ 1 + 2⁻²³`.
        let (mut finite, mut infinite) = (1u32, u32::MAX);
        while infinite - finite > 1 {
            let mid = finite + (infinite - finite) / 2;
            if q.level(mid).is_finite() {
                finite = mid;
            } else {
                infinite = mid;
            }
        }
        let (max_index, top) = (infinite, q.level(finite));
        q.max_index = max_index;
        let top_plus = top * q.one_plus_delta;
        q.saturation = if top_plus.is_finite() { top_plus } else { top };
        Ok(q)
    }

    /// `δ = (1−ρ)/(1+ρ)`: the sector of Lemma 3 is `1−δ ≤ P ≤ 1+δ`, and (28) divides by `1−δ`.
    ///
    /// ```
    /// use controller_core::{HysteresisQuantizer, QuantizerConfig};
    /// let q = HysteresisQuantizer::new(&QuantizerConfig::default())?; // ρ = 0.9
    /// assert!((q.delta() - 0.1 / 1.9).abs() < 1e-7);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn delta(&self) -> f32 {
        self.delta
    }

    /// `u_min`: the dead zone; commands up to it (on the way up) give 0.
    ///
    /// ```
    /// use controller_core::{HysteresisQuantizer, QuantizerConfig};
    /// let q = HysteresisQuantizer::new(&QuantizerConfig::default())?;
    /// assert_eq!(q.u_min(), 0.01);
    /// assert_eq!(q.quantize(&mut q.state(), q.u_min()), 0.0);
    /// assert_eq!(q.quantize(&mut q.state(), 0.0101), q.u_min());
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn u_min(&self) -> f32 {
        self.u_min
    }

    /// The largest output magnitude: the top finite level `u_c`, times `1+δ` where that stays
    /// finite. `|q|` never exceeds it.
    ///
    /// ```
    /// use controller_core::{HysteresisQuantizer, QuantizerConfig};
    /// let q = HysteresisQuantizer::new(&QuantizerConfig::default())?;
    /// // The paper's ρ = 0.9, u_min = 0.01: the top level is about 3.5e36.
    /// assert!(q.saturation() > 3e36 && q.saturation().is_finite());
    /// assert_eq!(q.quantize(&mut q.state(), f32::MAX), q.saturation());
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn saturation(&self) -> f32 {
        self.saturation
    }

    /// Level `u_c = u_min ρ^(1−c)` for `c ≥ 1`: `u_min · (1/ρ)^(c−1)` with the power formed
    /// exactly as [`math::powi`] forms it (the same bits), its low bits from the squarings. Out
    /// of line: called on level changes only, it keeps the quantizer small enough to inline.
    ///
    /// ```
    /// use controller_core::{HysteresisQuantizer, QuantizerConfig};
    /// let q = HysteresisQuantizer::new(&QuantizerConfig::default())?; // ρ = 0.9, u_min = 0.01
    /// assert_eq!(q.level(1), 0.01);
    /// for c in 1..50 {
    ///     let ratio = q.level(c) / q.level(c + 1);
    ///     assert!((ratio - 0.9).abs() < 1e-5); // successive levels differ by ρ
    /// }
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[inline(never)]
    #[must_use]
    pub fn level(&self, c: u32) -> f32 {
        let k = c.saturating_sub(1);
        let mut acc = 1.0;
        let mut low = k & ((1 << SQUARINGS) - 1);
        while low != 0 {
            if let Some(p) = self.squarings.get(low.trailing_zeros() as usize) {
                acc *= *p;
            }
            low &= low - 1;
        }
        let high = k >> SQUARINGS;
        if high != 0 {
            let top = self.squarings[SQUARINGS - 1];
            acc = math::mul_powi(acc, top * top, high);
        }
        self.u_min * acc
    }

    /// The initial state: `u_{−1} = 0`, `q_{−1} = 0`, so the first direction is `sign(u_0)`.
    ///
    /// ```
    /// use controller_core::{HysteresisQuantizer, QuantizerConfig};
    /// let q = HysteresisQuantizer::new(&QuantizerConfig::default())?;
    /// let s = q.state();
    /// assert_eq!((s.prev_u, s.prev_q), (0.0, 0.0));
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub fn state(&self) -> QuantizerState {
        QuantizerState {
            prev_u: 0.0,
            prev_q: 0.0,
            index: 1,
            lower: self.level(1),
            upper: self.level(2),
        }
    }

    /// Closed-form level index: the `c ≥ 1` with `u_c < b ≤ u_{c+1}` (`b > u_min`), or 1.
    ///
    /// ```
    /// use controller_core::{HysteresisQuantizer, QuantizerConfig};
    /// let q = HysteresisQuantizer::new(&QuantizerConfig { rho: 0.5, u_min: 1.0, ..Default::default() })?;
    /// // Levels 1, 2, 4, 8: u_2 = 2 < 3 ≤ 4 = u_3, and the bracket is closed above.
    /// assert_eq!(q.level_index(3.0), 2);
    /// assert_eq!(q.level_index(4.0), 2);
    /// assert_eq!(q.level_index(4.001), 3);
    /// assert_eq!(q.level_index(0.5), 1);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub fn level_index(&self, b: f32) -> u32 {
        if b <= self.u_min || !b.is_finite() {
            return 1;
        }
        let x = (math::ln_estimate(b) - self.ln_u_min) * self.inv_ln_inv_rho;
        let mut c = x as u32;
        if (c as f32) < x {
            c = c.saturating_add(1);
        }
        // Settle c on the levels as `level` computes them: `ln` rounding, and the rounding of
        // `1/ρ` raised to a large power, put the estimate off the answer, by one for the
        // paper's `ρ` and by thousands of levels for `ρ` next to 1. Galloping from the estimate
        // then bisecting keeps the work at O(log) of that distance (at most about 64 levels).
        let below = |c: u32| self.level(c) < b; // true at 1, false at max_index
        let (mut lo, mut hi) = (1, self.max_index);
        let start = c.clamp(1, self.max_index);
        let mut step = 1u32;
        if below(start) {
            lo = start;
            while lo < hi {
                let probe = lo.saturating_add(step).min(hi);
                if !below(probe) {
                    hi = probe;
                    break;
                }
                lo = probe;
                step = step.saturating_mul(2);
            }
        } else {
            hi = start;
            while lo < hi {
                let probe = hi.saturating_sub(step).max(lo);
                if below(probe) {
                    lo = probe;
                    break;
                }
                hi = probe;
                step = step.saturating_mul(2);
            }
        }
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if below(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// `q_k = Q(u_k)`, updating the state (eq. 2). The output is odd in `u`'s sign.
    ///
    /// Lemma 3: `q = P u + R` with `1−δ ≤ P ≤ 1+δ`, `|R| ≤ u_min`; away from the dead zone
    /// (here `|u| > 2 u_min`) the ratio `q/u` itself stays in that sector:
    ///
    /// ```
    /// use controller_core::{HysteresisQuantizer, QuantizerConfig};
    /// let q = HysteresisQuantizer::new(&QuantizerConfig::default())?;
    /// let d = q.delta();
    /// let mut s = q.state();
    /// for k in 0..2000 {
    ///     let u = 3.0 * (k as f32 * 0.01).sin(); // up and down through many levels
    ///     let out = q.quantize(&mut s, u);
    ///     assert!(out == 0.0 || out * u > 0.0);
    ///     if u.abs() > 2.0 * q.u_min() {
    ///         let p = out / u;
    ///         assert!(p >= 1.0 - d - 1e-6 && p <= 1.0 + d + 1e-6, "u = {u}, q = {out}");
    ///     }
    /// }
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[inline]
    pub fn quantize(&self, s: &mut QuantizerState, u: f32) -> f32 {
        let q = self.output(s.prev_u, s.prev_q, u, |b| {
            self.locate(s, b);
            s.lower
        });
        s.prev_u = u;
        s.prev_q = q;
        q
    }

    /// The same output as [`Self::quantize`] from the closed-form level index (the reference).
    ///
    /// ```
    /// use controller_core::{HysteresisQuantizer, QuantizerConfig};
    /// let q = HysteresisQuantizer::new(&QuantizerConfig::default())?;
    /// let mut s = q.state();
    /// let (mut prev_u, mut prev_q) = (0.0, 0.0);
    /// for u in [0.02, 0.5, 40.0, 0.013, -7.0, -7.5, 0.0] {
    ///     let reference = q.quantize_reference(prev_u, prev_q, u);
    ///     assert_eq!(q.quantize(&mut s, u), reference);
    ///     (prev_u, prev_q) = (u, reference);
    /// }
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub fn quantize_reference(&self, prev_u: f32, prev_q: f32, u: f32) -> f32 {
        self.output(prev_u, prev_q, u, |b| self.level(self.level_index(b)))
    }

    /// The cases of eq. (2); `level(b)` gives `u_c` of the bracket `u_c < b ≤ u_{c+1}`.
    #[inline]
    fn output(&self, prev_u: f32, prev_q: f32, u: f32, level: impl FnOnce(f32) -> f32) -> f32 {
        let Some(rising) = self.direction_of(prev_u, u) else {
            return prev_q;
        };
        let a = math::abs(u);
        let b = if rising {
            a
        } else {
            // `a (1+δ)` of a finite `a` can overflow: it still lies above every finite level.
            let b = a * self.one_plus_delta;
            if b > f32::MAX {
                f32::MAX
            } else {
                b
            }
        };
        if b <= self.u_min {
            0.0
        } else {
            math::sign(u) * self.magnitude(a, level(b), rising)
        }
    }

    /// `Some(true)` for `d > 0`, `Some(false)` for `d < 0`, `None` for the hold case `d = 0`.
    #[inline]
    fn direction_of(&self, prev: f32, u: f32) -> Option<bool> {
        if u == prev {
            return None;
        }
        match self.direction {
            QuantizerDirection::Signed => Some(u > prev),
            // A pure sign flip (|u| unchanged) is re-evaluated as rising.
            QuantizerDirection::Magnitude => Some(math::abs(u) >= math::abs(prev)),
        }
    }

    #[inline]
    fn magnitude(&self, a: f32, level: f32, rising: bool) -> f32 {
        let upper_edge = if rising {
            level * self.inv_one_minus_delta
        } else {
            level
        };
        let m = if a <= upper_edge {
            level
        } else {
            level * self.one_plus_delta
        };
        if m > self.saturation {
            self.saturation
        } else {
            m
        }
    }

    /// Moves the bracket to `u_c < b ≤ u_{c+1}` (`b > u_min`). Inline only the test that `b`
    /// is still in the bracket (most samples); a move is out of line ([`Self::relocate`]). The
    /// placeholder state (index 0, bracket `(0, 0]`) is outside for every such `b`.
    #[inline]
    fn locate(&self, s: &mut QuantizerState, b: f32) {
        if self.outside(s, b) {
            self.relocate(s, b);
        }
    }

    /// `b` lies beyond the bracket on a side that has a next level.
    #[inline]
    fn outside(&self, s: &QuantizerState, b: f32) -> bool {
        (b > s.upper && s.index < self.max_index) || (b <= s.lower && s.index > 1)
    }

    /// Level by level, each step computing one new level (the other bound is the previous
    /// one), up to [`MAX_WALK`] levels; beyond, the closed form.
    #[inline(never)]
    fn relocate(&self, s: &mut QuantizerState, b: f32) {
        // The placeholder state has no bracket yet; beyond about MAX_WALK levels (the bracket's
        // edge times (1/ρ)^4) the walk would end in the closed form anyway. Either path ends
        // on the same bracket: the choice costs work, not results.
        let far = self.squarings[FAR];
        if s.index == 0 || b > s.upper * far || b * far <= s.lower {
            return self.jump(s, b);
        }
        for _ in 0..MAX_WALK {
            if b > s.upper && s.index < self.max_index {
                s.index += 1;
                s.lower = s.upper;
                s.upper = self.level(s.index.saturating_add(1));
            } else if b <= s.lower && s.index > 1 {
                s.index -= 1;
                s.upper = s.lower;
                s.lower = self.level(s.index);
            } else {
                return;
            }
        }
        if self.outside(s, b) {
            self.jump(s, b);
        }
    }

    /// A jump of more than [`MAX_WALK`] levels: the closed form, kept out of the common path.
    #[cold]
    #[inline(never)]
    fn jump(&self, s: &mut QuantizerState, b: f32) {
        self.set_index(s, self.level_index(b));
    }

    #[inline]
    fn set_index(&self, s: &mut QuantizerState, c: u32) {
        s.index = c;
        s.lower = self.level(c);
        s.upper = self.level(c.saturating_add(1));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q09() -> HysteresisQuantizer {
        HysteresisQuantizer::new(&QuantizerConfig::default()).unwrap()
    }

    #[test]
    fn levels_and_delta() {
        let q = q09();
        assert!((q.delta() - 0.1 / 1.9).abs() < 1e-7);
        assert_eq!(q.level(1), 0.01);
        assert!((q.level(3) - 0.01 / 0.81).abs() < 1e-8);
        // b = 0.0105 lies in (u_1, u_2] = (0.01, 0.01111].
        assert_eq!(q.level_index(0.0105), 1);
        assert_eq!(q.level_index(0.0112), 2);
        assert_eq!(q.level_index(0.005), 1);
    }

    #[test]
    fn rising_and_falling_by_hand() {
        let q = q09();
        let mut s = q.state();
        // Rising from 0 to 0.0105: c = 1, a ≤ u_1/(1−δ) = 0.010556 → u_1.
        assert_eq!(q.quantize(&mut s, 0.0105), 0.01);
        // Rising to 0.011: above u_1/(1−δ) → u_1 (1+δ).
        let v = q.quantize(&mut s, 0.011);
        assert!((v - 0.01 * (1.0 + q.delta())).abs() < 1e-8);
        // Unchanged command: output held.
        assert_eq!(q.quantize(&mut s, 0.011), v);
        // Falling to 0.0098: b = a(1+δ) = 0.010316 > u_min, c = 1, a ≤ u_1 → u_1.
        assert_eq!(q.quantize(&mut s, 0.0098), 0.01);
        // Falling to 0.009: b = 0.009474 ≤ u_min → 0.
        assert_eq!(q.quantize(&mut s, 0.009), 0.0);
        // A jump to −1 is a falling command: b = 1+δ = 1.0526 lies in (u_45, u_46] =
        // (1.0312, 1.1458] and a = 1 ≤ u_45, so the output is −u_45.
        let v = q.quantize(&mut s, -1.0);
        assert_eq!(q.level_index(1.0 + q.delta()), 45);
        assert_eq!(v, -q.level(45));
        assert!((v + 1.0312).abs() < 1e-3);
    }

    #[test]
    fn incremental_equals_closed_form_on_a_sweep() {
        let q = q09();
        let mut s = q.state();
        let (mut pu, mut pq) = (0.0f32, 0.0f32);
        for k in 0..20_000 {
            let t = k as f32 * 1e-3;
            let u = 3.0 * libm::sinf(1.3 * t) * libm::expf(-0.1 * t) + 0.5 * libm::sinf(17.0 * t);
            let fast = q.quantize(&mut s, u);
            let slow = q.quantize_reference(pu, pq, u);
            assert_eq!(fast, slow, "k {k} u {u}");
            pu = u;
            pq = slow;
        }
    }

    #[test]
    fn levels_from_the_squarings_equal_powi_bit_for_bit() {
        for rho in [0.9f32, 0.5, 0.99, 0.999_9, 1.0 - 1e-7] {
            let q = HysteresisQuantizer::new(&QuantizerConfig {
                rho,
                ..QuantizerConfig::default()
            })
            .unwrap();
            let inv_rho = 1.0 / rho;
            let cs = (1..2_000).chain([255, 256, 257, 4_097, 65_537, q.max_index, u32::MAX]);
            for c in cs {
                let want = q.u_min * math::powi(inv_rho, c.saturating_sub(1));
                assert_eq!(q.level(c).to_bits(), want.to_bits(), "rho {rho} c {c}");
            }
        }
    }

    #[test]
    fn a_default_state_locates_by_the_closed_form() {
        let q = q09();
        for u in [0.5f32, -3.0, 0.0105, 1e20] {
            let mut s = QuantizerState::default();
            assert_eq!(
                q.quantize(&mut s, u),
                q.quantize_reference(0.0, 0.0, u),
                "u = {u}"
            );
            let mut fresh = q.state();
            q.quantize(&mut fresh, u);
            assert_eq!(s, fresh, "u = {u}");
        }
    }

    #[test]
    fn large_jumps_use_the_closed_form() {
        let q = q09();
        let mut s = q.state();
        for &u in &[1e6f32, 0.02, -3e30, f32::MAX, 0.5, -f32::MAX, 0.0] {
            let expect = q.quantize_reference(s.prev_u, s.prev_q, u);
            assert_eq!(q.quantize(&mut s, u), expect, "u = {u}");
        }
    }

    #[test]
    fn moves_walked_or_jumped_land_on_the_same_bracket() {
        // From every bracket c0, to every bracket c within 12 levels: b at either edge of
        // `u_c < b ≤ u_{c+1}`. Up to MAX_WALK levels walk, beyond jump: the state must be the
        // bracket `set_index` gives, bit for bit, on both sides of that threshold.
        for rho in [0.9f32, 0.5, 0.99] {
            let q = HysteresisQuantizer::new(&QuantizerConfig {
                rho,
                ..QuantizerConfig::default()
            })
            .unwrap();
            for c0 in 1..40u32 {
                for c in c0.saturating_sub(12).max(1)..c0 + 12 {
                    let (lo, hi) = (q.level(c), q.level(c + 1));
                    for b in [hi, f32::from_bits(lo.to_bits() + 1)] {
                        let mut s = q.state();
                        q.set_index(&mut s, c0);
                        q.locate(&mut s, b);
                        let mut want = s;
                        q.set_index(&mut want, c);
                        assert_eq!(s, want, "rho {rho}: {c0} → {c}, b {b}");
                    }
                }
            }
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        let bad = |rho, u_min| {
            HysteresisQuantizer::new(&QuantizerConfig {
                rho,
                u_min,
                direction: QuantizerDirection::Signed,
            })
        };
        let e = |p, r| Err(ConfigError::new(p, r));
        assert_eq!(bad(1.0, 0.01), e(Param::Rho, Reason::OutOfRange));
        assert_eq!(bad(0.0, 0.01), e(Param::Rho, Reason::OutOfRange));
        assert_eq!(bad(0.5, 0.0), e(Param::UMin, Reason::NonPositive));
        assert_eq!(bad(f32::NAN, 0.01), e(Param::Rho, Reason::NonFinite));
    }
}
