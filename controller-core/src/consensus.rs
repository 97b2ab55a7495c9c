//! The neighbour set and the consensus error `e_{i,1}` (LAW §2; the paper's (10)), with the
//! policy for stale, missing and invalid neighbour or leader values.
//!
//! Policy (documented in the crate docs and `docs/RELIABILITY.md`):
//! * [`Link::Fresh`] with a finite value: used and remembered.
//! * [`Link::Stale`] with a finite value: used (it is the latest value received: a zero-order
//!   hold) and counted as stale.
//! * A non-finite value (either kind): counted as invalid and handled as [`Link::Missing`].
//! * [`Link::Missing`]: the last valid value remembered for that link is used; if there never
//!   was one, the link's term is left out of `e_{i,1}` and of `Φ_1` for this sample (as if the
//!   neighbour agreed with the agent) and the link is counted as missing.

use crate::mtn::MtnAccumulator;

/// One value received over the network, as the node hands it to the controller.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link};
/// let cfg = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
/// let mut c = Controller::<2, 2, 1>::new(&cfg)?;
/// // e_1 = (y − y_1) + (y − y_d) = (0.1 − 0.3) + (0.1 − 0) (10).
/// let out = c.step(&[0.1, 0.0], &[Link::Fresh(0.3)], Link::Fresh(0.0));
/// assert!((out.e[0] + 0.1).abs() < 1e-6);
/// // A NaN is counted as invalid and replaced by the last valid value.
/// let out = c.step(&[0.1, 0.0], &[Link::Fresh(f32::NAN)], Link::Stale(0.0));
/// assert!((out.e[0] + 0.1).abs() < 1e-6);
/// assert_eq!(out.status.links.invalid_neighbours, 1);
/// assert!(out.status.links.leader_stale);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Link {
    /// Received within the freshness timeout.
    Fresh(f32),
    /// The latest value received, but older than the timeout.
    Stale(f32),
    /// Nothing usable received.
    Missing,
}

/// Counts of degraded links in one sample.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link};
/// let cfg = ControllerConfig::<2> { neighbour_count: 2, ..Default::default() };
/// let mut c = Controller::<2, 2, 2>::new(&cfg)?;
/// // Neighbour 2 never sent anything: its term is left out of e_1, as if it agreed.
/// let r = c.step(&[0.1, 0.0], &[Link::Fresh(0.1), Link::Missing], Link::Missing).status.links;
/// assert_eq!((r.missing_neighbours, r.dropped_neighbours), (1, 1));
/// assert!(r.leader_missing && r.leader_dropped && !r.count_mismatch);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkReport {
    /// Neighbour values used although stale.
    pub stale_neighbours: u8,
    /// Neighbours with no usable value this sample (remembered value used, or term left out).
    pub missing_neighbours: u8,
    /// Neighbour values that were NaN or infinite.
    pub invalid_neighbours: u8,
    /// Neighbour terms left out of `e_{i,1}` (never a valid value).
    pub dropped_neighbours: u8,
    /// The slice of neighbour values did not have the configured length.
    pub count_mismatch: bool,
    /// The leader value was stale.
    pub leader_stale: bool,
    /// The leader value was missing or invalid this sample.
    pub leader_missing: bool,
    /// The leader term was left out of `e_{i,1}` (pinned, but never a valid leader value).
    pub leader_dropped: bool,
}

impl LinkReport {
    /// Every link fresh and valid.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig, Link, LinkReport};
    /// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
    /// assert!(c.step(&[0.0; 2], &[], Link::Fresh(0.0)).status.links.is_clean());
    /// assert!(!c.step(&[0.0; 2], &[], Link::Stale(0.0)).status.links.is_clean());
    /// assert!(LinkReport::default().is_clean());
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub fn is_clean(&self) -> bool {
        *self == Self::default()
    }
}

/// The last valid value of one link.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link};
/// let cfg = ControllerConfig::<2> { neighbour_count: 1, pinned: false, ..Default::default() };
/// let mut c = Controller::<2, 1, 1>::new(&cfg)?;
/// c.step(&[0.0, 0.0], &[Link::Fresh(0.3)], Link::Missing);
/// // An infinite value is not held: e_1 = y − 0.3 with the last valid y_1.
/// let out = c.step(&[0.0, 0.0], &[Link::Fresh(f32::INFINITY)], Link::Missing);
/// assert!((out.e[0] + 0.3).abs() < 1e-6);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Held {
    value: f32,
    valid: bool,
}

/// Remembered neighbour and leader values of one agent (`K` neighbour slots).
///
/// ```
/// use controller_core::consensus::{Consensus, LinkMemory};
/// use controller_core::{Link, LinkReport, MtnRegressor};
/// let (graph, mut memory) = (Consensus::new(1, false), LinkMemory::<1>::default());
/// let mtn = MtnRegressor::new(2)?;
/// let mut e1 = |link| {
///     let mut report = LinkReport::default();
///     graph.consensus_error(&mut memory, 0.0, &[link], Link::Missing, &mut mtn.accumulator(),
///                           &mut report, |_, l| l)
/// };
/// assert_eq!(e1(Link::Fresh(0.4)), -0.4);
/// assert_eq!(e1(Link::Missing), -0.4); // remembered
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkMemory<const K: usize> {
    neighbours: [Held; K],
    leader: Held,
}

impl<const K: usize> Default for LinkMemory<K> {
    fn default() -> Self {
        Self {
            neighbours: [Held::default(); K],
            leader: Held::default(),
        }
    }
}

/// What a link resolved to.
enum Resolved {
    Value(f32),
    Stale(f32),
    Remembered(f32, bool),
    Dropped(bool),
}

impl Held {
    fn resolve(&mut self, link: Link) -> Resolved {
        let (v, stale) = match link {
            Link::Fresh(v) => (v, false),
            Link::Stale(v) => (v, true),
            Link::Missing => return self.fallback(false),
        };
        if !v.is_finite() {
            return self.fallback(true);
        }
        self.value = v;
        self.valid = true;
        if stale {
            Resolved::Stale(v)
        } else {
            Resolved::Value(v)
        }
    }

    fn fallback(&self, invalid: bool) -> Resolved {
        if self.valid {
            Resolved::Remembered(self.value, invalid)
        } else {
            Resolved::Dropped(invalid)
        }
    }
}

/// The agent's place in the graph: `S_i` neighbours, pinned or not (LAW §2).
///
/// ```
/// use controller_core::consensus::Consensus;
/// // The paper's examples: agent 1 hears the leader only, agent 4 hears agents 1 and 3.
/// let (agent1, agent4) = (Consensus::new(0, true), Consensus::new(2, false));
/// assert_eq!((agent1.a(), agent1.s()), (1.0, 0.0));
/// assert_eq!((agent4.a(), agent4.s()), (2.0, 2.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Consensus {
    neighbours: u8,
    pinned: bool,
}

impl Consensus {
    /// `S_i` neighbours (at most `K`, checked by the controller's config) and the pinning `r_i`.
    ///
    /// ```
    /// use controller_core::consensus::Consensus;
    /// let c = Consensus::new(3, true);
    /// assert_eq!((c.neighbour_count(), c.a()), (3, 4.0));
    /// ```
    #[must_use]
    pub const fn new(neighbours: u8, pinned: bool) -> Self {
        Self { neighbours, pinned }
    }

    /// `S_i` as a count: the number of neighbour values `step` expects.
    ///
    /// ```
    /// use controller_core::consensus::Consensus;
    /// assert_eq!(Consensus::new(2, false).neighbour_count(), 2);
    /// ```
    #[must_use]
    pub const fn neighbour_count(&self) -> usize {
        self.neighbours as usize
    }

    /// `S_i = Σ_k a_{i,k}`: with `A_i` it sets step 1's damping `(1 + A_i + S_i)/2` (17).
    ///
    /// ```
    /// use controller_core::consensus::Consensus;
    /// let c = Consensus::new(2, true);
    /// assert_eq!((1.0 + c.a() + c.s()) / 2.0, 3.0);
    /// ```
    #[must_use]
    pub const fn s(&self) -> f32 {
        self.neighbours as f32
    }

    /// `A_i = S_i + r_i`.
    ///
    /// ```
    /// use controller_core::consensus::Consensus;
    /// assert_eq!(Consensus::new(1, true).a(), 2.0);
    /// assert_eq!(Consensus::new(0, false).a(), 0.0); // isolated: rejected by the config
    /// ```
    #[must_use]
    pub const fn a(&self) -> f32 {
        self.neighbours as f32 + if self.pinned { 1.0 } else { 0.0 }
    }

    /// `e_{i,1} = Σ_k a_{i,k}(y_i − y_k) + r_i(y_i − y_d)` (10); pushes `X_{i,1} = [y_i, y_k…]`
    /// into `phi` for `‖Φ_1‖²`. Each neighbour value the law reads passes first through
    /// `through(k, link)`: the identity, or the safety layer's re-entry of slot `k`.
    ///
    /// ```
    /// use controller_core::consensus::{Consensus, LinkMemory};
    /// use controller_core::{Link, LinkReport, MtnRegressor};
    /// // Agent 4: neighbours 1 and 3, not pinned; y_4 = 0.5, y_1 = 0.2, y_3 = 0.1.
    /// let graph = Consensus::new(2, false);
    /// let mut memory = LinkMemory::<2>::default();
    /// let mtn = MtnRegressor::new(1)?;
    /// let (mut phi, mut report) = (mtn.accumulator(), LinkReport::default());
    /// let links = [Link::Fresh(0.2), Link::Fresh(0.1)];
    /// let e1 = graph.consensus_error(&mut memory, 0.5, &links, Link::Missing, &mut phi,
    ///                                &mut report, |_, l| l);
    /// assert!((e1 - 0.7).abs() < 1e-6); // (0.5 − 0.2) + (0.5 − 0.1)
    /// // X_{4,1} = (y_4, y_1, y_3) went into Φ_1: with m = 1, ‖Φ_1‖² = ‖X‖².
    /// assert!((phi.norm_sq() - 0.30).abs() < 1e-6);
    /// assert!(report.is_clean());
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[allow(clippy::too_many_arguments)]
    pub fn consensus_error<const K: usize>(
        &self,
        memory: &mut LinkMemory<K>,
        y: f32,
        neighbours: &[Link],
        leader: Link,
        phi: &mut MtnAccumulator,
        report: &mut LinkReport,
        mut through: impl FnMut(usize, Link) -> Link,
    ) -> f32 {
        report.count_mismatch = neighbours.len() != self.neighbours as usize;
        phi.push(y);
        let mut e = 0.0;
        let slots = memory.neighbours.iter_mut().take(self.neighbours as usize);
        for (k, held) in slots.enumerate() {
            let link = neighbours
                .get(k)
                .map_or(Link::Missing, |&link| through(k, link));
            let yk = match held.resolve(link) {
                Resolved::Value(v) => Some(v),
                Resolved::Stale(v) => {
                    report.stale_neighbours += 1;
                    Some(v)
                }
                Resolved::Remembered(v, invalid) => {
                    report.missing_neighbours += 1;
                    report.invalid_neighbours += u8::from(invalid);
                    Some(v)
                }
                Resolved::Dropped(invalid) => {
                    report.missing_neighbours += 1;
                    report.invalid_neighbours += u8::from(invalid);
                    report.dropped_neighbours += 1;
                    None
                }
            };
            if let Some(yk) = yk {
                e += y - yk;
                phi.push(yk);
            }
        }
        if self.pinned {
            let yd = match memory.leader.resolve(leader) {
                Resolved::Value(v) => Some(v),
                Resolved::Stale(v) => {
                    report.leader_stale = true;
                    Some(v)
                }
                Resolved::Remembered(v, _) => {
                    report.leader_missing = true;
                    Some(v)
                }
                Resolved::Dropped(_) => {
                    report.leader_missing = true;
                    report.leader_dropped = true;
                    None
                }
            };
            if let Some(yd) = yd {
                e += y - yd;
            }
        }
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MtnRegressor;

    fn run(
        c: &Consensus,
        mem: &mut LinkMemory<4>,
        y: f32,
        n: &[Link],
        l: Link,
    ) -> (f32, LinkReport) {
        let mut acc = MtnRegressor::new(1).unwrap().accumulator();
        let mut r = LinkReport::default();
        let e = c.consensus_error(mem, y, n, l, &mut acc, &mut r, |_, link| link);
        (e, r)
    }

    #[test]
    fn consensus_error_by_hand() {
        // Agent 4 of the examples: hears agents 1 and 3, not pinned.
        let c = Consensus::new(2, false);
        assert_eq!((c.a(), c.s()), (2.0, 2.0));
        let mut m = LinkMemory::default();
        let (e, r) = run(
            &c,
            &mut m,
            1.0,
            &[Link::Fresh(0.5), Link::Fresh(2.0)],
            Link::Missing,
        );
        assert_eq!(e, (1.0 - 0.5) + (1.0 - 2.0));
        assert!(r.is_clean());
        // Pinned agent: leader term added.
        let p = Consensus::new(0, true);
        let (e, r) = run(&p, &mut m, 1.0, &[], Link::Fresh(0.25));
        assert_eq!(e, 0.75);
        assert!(r.is_clean());
    }

    #[test]
    fn stale_missing_and_invalid_policy() {
        let c = Consensus::new(2, true);
        let mut m = LinkMemory::default();
        // Nothing ever received: both neighbour terms and the leader are dropped.
        let (e, r) = run(
            &c,
            &mut m,
            1.0,
            &[Link::Missing, Link::Fresh(f32::NAN)],
            Link::Missing,
        );
        assert_eq!(e, 0.0);
        assert_eq!(
            (
                r.missing_neighbours,
                r.invalid_neighbours,
                r.dropped_neighbours
            ),
            (2, 1, 2)
        );
        assert!(r.leader_dropped);
        // Valid values arrive and are remembered.
        let (e, _) = run(
            &c,
            &mut m,
            1.0,
            &[Link::Fresh(0.5), Link::Stale(0.0)],
            Link::Fresh(0.0),
        );
        assert_eq!(e, 0.5 + 1.0 + 1.0);
        // Then they vanish or turn invalid: the remembered values are used.
        let (e2, r) = run(
            &c,
            &mut m,
            1.0,
            &[Link::Stale(f32::INFINITY)],
            Link::Missing,
        );
        assert_eq!(e2, e);
        assert!(r.count_mismatch && r.leader_missing && !r.leader_dropped);
        assert_eq!(
            (
                r.missing_neighbours,
                r.invalid_neighbours,
                r.dropped_neighbours
            ),
            (2, 1, 0)
        );
    }
}
