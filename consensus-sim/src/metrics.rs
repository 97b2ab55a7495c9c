//! The metrics of LAW §11 with the definitions of docs/SCENARIO.md, accumulated sample by sample,
//! the `[metrics]` section that tunes them, and the `summary.json` they fill.

pub mod spec;

use std::collections::BTreeMap;

use controller_core::Gains;
use serde::Serialize;

pub use spec::{MetricsSpec, WindowKind, WindowSpec};

use crate::{
    clock::ClockSummary,
    figures::{FirmwareSummary, KindReport, NetworkSummary, SocketcanSummary, SOCKETCAN_UNITS},
    scenario::{SchemeName, Setup},
    sim::{Divergence, Observer, SampleView},
};
use consensus_plot::error::Result;

/// The instant a scheme promises to be settled by \[s\], and its name: `2 T_s` for the
/// predefined-time law (Theorem 1), `t_prescribed` (default `T_s`) for the LAW §10 baseline.
pub fn deadline(setup: &Setup) -> (f64, &'static str) {
    let c = &setup.scenario.controller;
    match c.scheme {
        SchemeName::PredefinedTime => (setup.predefined_time(), "2Ts"),
        SchemeName::PrescribedTime => (c.t_prescribed.unwrap_or(c.ts), "t_prescribed"),
    }
}

/// The dwell of `settling_time` \[s\]: `[metrics] settle_dwell`, else the scheme's deadline.
pub fn settle_dwell(setup: &Setup) -> f64 {
    setup
        .scenario
        .metrics
        .settle_dwell
        .unwrap_or_else(|| deadline(setup).0)
}

/// One entry of `summary.json` `windows`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WindowValue {
    /// The window's name.
    pub name: String,
    /// `max_error`, `iae` or `energy`.
    pub kind: WindowKind,
    /// Start \[s\].
    pub from: f64,
    /// End \[s\] (the horizon when the scenario leaves it open).
    pub to: f64,
    /// The figure; null when no sample lies in the window (or the run diverged before it).
    pub value: Option<f64>,
    /// Unit of `value`.
    pub unit: &'static str,
}

/// Per-agent figures of `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AgentSummary {
    /// 1-based agent.
    pub agent: usize,
    /// `Σ |y_i − y_d| h`.
    pub iae: f64,
    /// `Σ (y_i − y_d)² h`.
    pub ise: f64,
    /// `max |u_{i,l}|`.
    pub max_abs_u: f64,
    /// `∫ Σ_l u_l² dt` (the commands are held, so the sum is exact).
    pub u_energy: f64,
    /// Samples at which a quantized output changed, summed over actuators.
    pub quantizer_changes: u64,
    /// Distinct non-zero quantizer levels `|q|` used (null without quantizer).
    pub levels_used: Option<usize>,
    /// `max |x_{i,j}|` over the samples.
    pub peak_abs_state: f64,
    /// `μ̂` at the last sample.
    pub final_mu: f64,
    /// `ξ̂` at the last sample.
    pub final_xi: f64,
    /// `λ̂` at the last sample.
    pub final_lambda: f64,
    /// Samples at which the controller held its command (non-finite input or result).
    pub step_faults: u64,
}

/// `summary.json` (docs/SCENARIO.md keys, plus run facts).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// `predefined-time` or `prescribed-time`.
    pub scheme: String,
    /// Plant model.
    pub model: String,
    /// Sample period \[s\].
    pub h: f64,
    /// Horizon \[s\].
    pub t_end: f64,
    /// Samples `K` simulated (fewer if the run diverged).
    pub samples: u64,
    /// `c_1` in force.
    pub c1: f64,
    /// `c_2` in force.
    pub c2: f64,
    /// `k_1`.
    pub k1: f64,
    /// `k_2`.
    pub k2: f64,
    /// Whether the quantizer was on.
    pub quantizer: bool,
    /// Whether actuator faults were on.
    pub faults: bool,
    /// `2 T_s`.
    pub predefined_time: f64,
    /// Band `b`.
    pub settle_band: f64,
    /// `t_{k+1}` of the last sample outside the band, provided the samples from there to the
    /// last one span the dwell ([`settle_dwell`]); null otherwise or on divergence.
    pub settling_time: Option<f64>,
    /// `max_{i, t_k ≥ 2Ts} |y_i − y_d|`; null without such samples.
    pub max_error_after_predefined_time: Option<f64>,
    /// `max |u|` over agents and actuators.
    pub max_abs_u: f64,
    /// `Σ_i u_energy`.
    pub total_u_energy: f64,
    /// Share of actuator-samples whose command a `[safety]` limit changed (0 with safety off).
    pub saturated_fraction: f64,
    /// The run stopped on divergence.
    pub diverged: bool,
    /// Where and when.
    pub divergence: Option<Divergence>,
    /// Per agent.
    pub agents: Vec<AgentSummary>,
    /// Network figures (`[network] kind = "can"`); absent for the ideal link.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub network: Option<NetworkSummary>,
    /// The unit of every numeric key above, dotted for nested ones (`agents.iae`).
    pub units: BTreeMap<&'static str, &'static str>,
    /// Node-firmware figures per agent (`[network] kind = "pil"`); absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub firmware: Option<Vec<FirmwareSummary>>,
    /// Real-time figures of a run on a Linux CAN interface (`[network] kind = "socketcan"`);
    /// absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub socketcan: Option<SocketcanSummary>,
    /// `[[metrics.window]]` figures; absent without windows.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub windows: Vec<WindowValue>,
    /// Clock figures (an active `[clock]`, docs/CLOCKS.md); absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clock: Option<ClockSummary>,
}

impl Summary {
    /// The figure of the window `name`.
    pub fn window(&self, name: &str) -> Option<f64> {
        self.windows
            .iter()
            .find(|w| w.name == name)
            .and_then(|w| w.value)
    }
}

/// Units of the numeric keys of `summary.json`: `[y]`, `[u]`, `[x]` are the units of the plant's
/// output, actuator commands and states (docs/SCENARIO.md §2).
const UNITS: [(&str, &str); 28] = [
    ("h", "s"),
    ("t_end", "s"),
    ("samples", "count"),
    ("c1", "1/s"),
    ("c2", "1/s"),
    ("k1", "1/s"),
    ("k2", "1/s"),
    ("predefined_time", "s"),
    ("settle_band", "[y]"),
    ("settling_time", "s"),
    ("max_error_after_predefined_time", "[y]"),
    ("max_abs_u", "[u]"),
    ("total_u_energy", "[u]^2 s"),
    ("saturated_fraction", "-"),
    ("divergence.time", "s"),
    ("divergence.agent", "1-based index"),
    ("agents.agent", "1-based index"),
    ("agents.iae", "[y] s"),
    ("agents.ise", "[y]^2 s"),
    ("agents.max_abs_u", "[u]"),
    ("agents.u_energy", "[u]^2 s"),
    ("agents.quantizer_changes", "count"),
    ("agents.levels_used", "count"),
    ("agents.peak_abs_state", "[x]"),
    ("agents.final_mu", "-"),
    ("agents.final_xi", "-"),
    ("agents.final_lambda", "-"),
    ("agents.step_faults", "count"),
];

/// Units of `windows`' numeric keys (`value`: its entry's `unit`).
const WINDOW_UNITS: [(&str, &str); 3] = [
    ("windows.from", "s"),
    ("windows.to", "s"),
    ("windows.value", "windows.unit"),
];

/// Units of `network`'s numeric keys (CAN runs).
const NETWORK_UNITS: [(&str, &str); 14] = [
    ("network.bitrate", "bit/s"),
    ("network.bus_load_percent", "%"),
    ("network.frames_sent", "count"),
    ("network.frames_lost", "count"),
    ("network.frames_corrupted", "count"),
    ("network.deadline_misses", "count"),
    ("network.bus_off_events", "count"),
    ("network.max_age_s", "s"),
    ("network.mean_age_s", "s"),
    ("network.max_latency_s", "s"),
    ("network.malformed", "count"),
    ("network.stale_samples", "count"),
    ("network.suppressed", "count"),
    ("network.babble_frames", "count"),
];

/// Units of `network.nodes`' numeric keys (CAN runs with a `[node]` section).
const NODE_UNITS: [(&str, &str); 4] = [
    ("network.nodes.agent", "1-based index"),
    ("network.nodes.safe_state_entries", "count"),
    ("network.nodes.overruns", "count"),
    ("network.nodes.heartbeats_sent", "count"),
];

/// Units of `clock`'s numeric keys (clocked runs).
const CLOCK_UNITS: [(&str, &str); 9] = [
    ("clock.sample_age.median", "samples"),
    ("clock.sample_age.p99", "samples"),
    ("clock.sample_age.max", "samples"),
    ("clock.sample_age.count", "count"),
    ("clock.sampling_error.median", "samples"),
    ("clock.sampling_error.p99", "samples"),
    ("clock.sampling_error.max", "samples"),
    ("clock.sampling_error.count", "count"),
    ("clock.samples_taken", "count"),
];

/// Units of `firmware`'s numeric keys (PIL runs).
const FIRMWARE_UNITS: [(&str, &str); 11] = [
    ("firmware.agent", "1-based index"),
    ("firmware.steps", "count"),
    ("firmware.instructions_min", "instructions per Node::tick"),
    (
        "firmware.instructions_median",
        "instructions per Node::tick",
    ),
    ("firmware.instructions_p99", "instructions per Node::tick"),
    ("firmware.instructions_max", "instructions per Node::tick"),
    ("firmware.instructions_resolution", "instructions"),
    ("firmware.stack_bytes", "B"),
    ("firmware.overruns", "count"),
    ("firmware.resets", "count"),
    ("firmware.safe_state_entries", "count"),
];

impl Summary {
    /// Sets what the agents of the run's network kind report (`network`, `firmware`,
    /// `socketcan`, and their units).
    pub fn set_report(&mut self, report: KindReport) {
        match report {
            KindReport::Ideal => {}
            KindReport::Can(network) => self.set_network(Some(network)),
            KindReport::Pil { network, firmware } => {
                self.set_network(Some(network));
                self.set_firmware(Some(firmware));
            }
            KindReport::Socketcan(s) => self.set_socketcan(Some(s)),
        }
    }

    /// Sets the network figures (and their units).
    pub fn set_network(&mut self, network: Option<NetworkSummary>) {
        if let Some(n) = &network {
            self.units.extend(NETWORK_UNITS);
            if !n.nodes.is_empty() {
                self.units.extend(NODE_UNITS);
            }
            if n.data_bitrate.is_some() {
                self.units.insert("network.data_bitrate", "bit/s");
            }
        }
        self.network = network;
    }

    /// Sets the clock figures of a clocked run (and their units).
    pub fn set_clock(&mut self, clock: Option<ClockSummary>) {
        if clock.is_some() {
            self.units.extend(CLOCK_UNITS);
        }
        self.clock = clock;
    }

    /// Sets the real-time figures of a run on a Linux CAN interface (and their units).
    pub fn set_socketcan(&mut self, socketcan: Option<SocketcanSummary>) {
        if socketcan.is_some() {
            self.units.extend(SOCKETCAN_UNITS);
        }
        self.socketcan = socketcan;
    }

    /// Sets the node-firmware figures of a PIL run (and their units).
    pub fn set_firmware(&mut self, firmware: Option<Vec<FirmwareSummary>>) {
        if firmware.is_some() {
            self.units.extend(FIRMWARE_UNITS);
        }
        self.firmware = firmware;
    }
}

#[derive(Debug, Clone, Default)]
struct Acc {
    iae: f64,
    ise: f64,
    max_abs_u: f64,
    u_energy: f64,
    changes: u64,
    /// Distinct `|q|` bits seen, sorted (a quantizer has some dozens of levels: a binary
    /// search beats hashing).
    levels: Vec<u32>,
    /// Index in `levels` of the level last added or found: a quantizer moves to the same
    /// magnitude (a sign change, the other actuator) or a neighbouring level, found without a
    /// search.
    at: usize,
    /// `levels[at]` (0 before the first level, which no level equals), kept here to spare
    /// the common case a memory access.
    cur: u32,
    peak: f64,
    est: [f32; 3],
    faults: u64,
    limited: u64,
}

impl Acc {
    /// Adds the level of bits `bits` to `levels` if it is new.
    #[inline]
    fn see_level(&mut self, bits: u32) {
        if bits == self.cur {
            return;
        }
        self.cur = bits;
        let near = self.at.saturating_sub(1)..(self.at + 2).min(self.levels.len());
        if let Some(k) = self.levels[near.clone()].iter().position(|&l| l == bits) {
            self.at = near.start + k;
            return;
        }
        self.at = match self.levels.binary_search(&bits) {
            Ok(at) => at,
            Err(at) => {
                self.levels.insert(at, bits);
                at
            }
        };
    }
}

/// A window's sample range and running figure.
#[derive(Debug, Clone)]
struct WindowAcc {
    k_from: u64,
    k_to: u64,
    kind: WindowKind,
    value: Option<f64>,
}

/// The first sample index at or after `t` [s].
fn first_at(t: f64, h: f64) -> u64 {
    (t / h - 1e-9).ceil().max(0.0) as u64
}

/// Accumulates the metrics while the loop runs.
#[derive(Debug, Clone)]
pub struct Metrics {
    h: f64,
    band: f64,
    dwell_samples: u64,
    windows: Vec<WindowAcc>,
    k_after: u64,
    levels: bool,
    seen: u64,
    last_outside: Option<u64>,
    max_after: Option<f64>,
    prev_q: Vec<f32>,
    m: usize,
    agents: Vec<Acc>,
}

impl Metrics {
    /// For the scenario of `setup`.
    pub fn new(setup: &Setup) -> Self {
        let sim = &setup.scenario.simulation;
        let windows = setup
            .scenario
            .metrics
            .window
            .iter()
            .map(|w| WindowAcc {
                k_from: first_at(w.from, sim.h),
                k_to: w
                    .to
                    .map_or(u64::MAX, |to| (to / sim.h + 1e-9).floor().max(0.0) as u64),
                kind: w.kind,
                value: None,
            })
            .collect();
        Self {
            h: sim.h,
            band: sim.settle_band,
            dwell_samples: first_at(settle_dwell(setup), sim.h).max(1),
            windows,
            k_after: first_at(setup.predefined_time(), sim.h),
            levels: setup.scenario.quantizer.enabled,
            seen: 0,
            last_outside: None,
            max_after: None,
            prev_q: vec![0.0; setup.agents() * setup.m()],
            m: setup.m(),
            agents: vec![Acc::default(); setup.agents()],
        }
    }

    /// The figures of `summary.json`.
    pub fn summary(&self, setup: &Setup, gains: &Gains, divergence: Option<Divergence>) -> Summary {
        let s = &setup.scenario;
        // Samples `first_inside..seen` are inside; their span `t_{seen-1} − t_{first_inside}`
        // must reach the dwell, so the last sample's time is never a settling time.
        let first_inside = self.last_outside.map_or(0, |k| k + 1);
        let settling_time = (divergence.is_none()
            && self.seen > first_inside
            && self.seen - 1 - first_inside >= self.dwell_samples)
            .then_some(first_inside as f64 * self.h);
        let agents: Vec<AgentSummary> = self
            .agents
            .iter()
            .enumerate()
            .map(|(i, a)| AgentSummary {
                agent: i + 1,
                iae: a.iae,
                ise: a.ise,
                max_abs_u: a.max_abs_u,
                u_energy: a.u_energy,
                quantizer_changes: a.changes,
                levels_used: self.levels.then_some(a.levels.len()),
                peak_abs_state: a.peak,
                final_mu: f64::from(a.est[0]),
                final_xi: f64::from(a.est[1]),
                final_lambda: f64::from(a.est[2]),
                step_faults: a.faults,
            })
            .collect();
        Summary {
            scenario: s.name.clone(),
            scheme: s.controller.scheme.to_string(),
            model: setup.plant.name().into(),
            h: s.simulation.h,
            t_end: s.simulation.t_end,
            samples: self.seen,
            c1: f64::from(gains.c1),
            c2: f64::from(gains.c2),
            k1: f64::from(gains.k1),
            k2: f64::from(gains.k2),
            quantizer: s.quantizer.enabled,
            faults: s.faults.enabled,
            predefined_time: setup.predefined_time(),
            settle_band: self.band,
            settling_time,
            max_error_after_predefined_time: self.max_after,
            max_abs_u: agents.iter().map(|a| a.max_abs_u).fold(0.0, f64::max),
            total_u_energy: agents.iter().map(|a| a.u_energy).sum(),
            saturated_fraction: {
                let actuator_samples = (self.seen * (self.m * self.agents.len()) as u64).max(1);
                let limited: u64 = self.agents.iter().map(|a| a.limited).sum();
                limited as f64 * self.m as f64 / actuator_samples as f64
            },
            diverged: divergence.is_some(),
            divergence,
            agents,
            units: {
                let mut u = BTreeMap::from(UNITS);
                if !self.windows.is_empty() {
                    u.extend(WINDOW_UNITS);
                }
                u
            },
            network: None,
            firmware: None,
            clock: None,
            socketcan: None,
            windows: s
                .metrics
                .window
                .iter()
                .zip(&self.windows)
                .map(|(w, a)| WindowValue {
                    name: w.name.clone(),
                    kind: w.kind,
                    from: w.from,
                    to: w.to.unwrap_or(s.simulation.t_end),
                    value: a.value,
                    unit: w.kind.unit(),
                })
                .collect(),
        }
    }
}

impl<const N: usize, const M: usize> Observer<N, M> for Metrics {
    fn sample(&mut self, s: &SampleView<'_, N, M>) -> Result<()> {
        let h = self.h;
        let mut worst: f64 = 0.0;
        let (mut err_sum, mut u2_sum) = (0.0, 0.0);
        for (i, (x, o)) in s.x.iter().zip(s.out).enumerate() {
            let a = &mut self.agents[i];
            let err = (x[0] - s.yd).abs();
            worst = worst.max(err);
            err_sum += err;
            a.iae += err * h;
            a.ise += err * err * h;
            for v in x {
                a.peak = a.peak.max(v.abs());
            }
            let prev = &mut self.prev_q[i * M..(i + 1) * M];
            for ((&u, &q), p) in o.u.iter().zip(&o.q).zip(prev.iter_mut()) {
                let u = f64::from(u);
                a.max_abs_u = a.max_abs_u.max(u.abs());
                a.u_energy += u * u * h;
                u2_sum += u * u;
                if q != *p {
                    a.changes += 1;
                    *p = q;
                    if self.levels && q != 0.0 {
                        a.see_level(q.abs().to_bits());
                    }
                }
            }
            a.est = [o.estimates.mu, o.estimates.xi, o.estimates.lambda];
            if o.status.fault.is_some() {
                a.faults += 1;
            }
            // One command for all actuators (DEVIATIONS §2): all or none are at a limit.
            a.limited += u64::from(o.status.limited);
        }
        if worst > self.band {
            self.last_outside = Some(s.k);
        }
        if s.k >= self.k_after {
            self.max_after = Some(self.max_after.map_or(worst, |m| m.max(worst)));
        }
        for w in &mut self.windows {
            if (w.k_from..=w.k_to).contains(&s.k) {
                let v = w.value.unwrap_or(0.0);
                w.value = Some(match w.kind {
                    WindowKind::MaxError => v.max(worst),
                    WindowKind::Iae => v + err_sum * h,
                    WindowKind::Energy => v + u2_sum * h,
                });
            }
        }
        self.seen = s.k + 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::{Estimates, StepOutput, StepStatus};

    fn out(u: f32, q: f32) -> StepOutput<2, 2> {
        StepOutput {
            u: [u; 2],
            q: [q; 2],
            e: [0.0; 2],
            alpha: [0.0; 2],
            beta: [0.0; 2],
            estimates: Estimates {
                mu: 1.0,
                xi: 2.0,
                lambda: 3.0,
            },
            varpi: 0.1,
            status: StepStatus::default(),
        }
    }

    /// One agent, h = 1, Ts = 1 (2Ts = 2), band 0.5, settle dwell 1 s, the given errors.
    fn feed(errors: &[f64]) -> consensus_plot::error::Result<Summary> {
        feed_with(errors, "[metrics]\nsettle_dwell = 1.0")
    }

    /// [`feed`] with `extra` TOML appended to the scenario instead of its dwell.
    fn feed_with(errors: &[f64], extra: &str) -> consensus_plot::error::Result<Summary> {
        let text = format!(
            "[simulation]\nh = 1.0\nt_end = 5.0\nsettle_band = 0.5\n\
             [graph]\nneighbours = [[]]\npinned = [1]\n[plant]\nx0 = [[0, 0]]\n\
             [controller]\nts = 1.0\n{extra}"
        );
        let setup = crate::scenario::parse(&text, &[])?;
        let mut m = Metrics::new(&setup);
        let qs = [0.0f32, 0.5, 0.5, 0.7, 0.5];
        for (k, (&e, &q)) in errors.iter().zip(&qs).enumerate() {
            let x = [[e, 0.0]];
            let o = [out(2.0, q)];
            let view = SampleView {
                k: k as u64,
                t: k as f64,
                yd: 0.0,
                x: &x,
                out: &o,
            };
            Observer::<2, 2>::sample(&mut m, &view)?;
        }
        let gains = Gains {
            c1: 1.0,
            c2: 1.0,
            k1: 1.0,
            k2: 1.0,
        };
        Ok(m.summary(&setup, &gains, None))
    }

    /// The level count equals a set's over seeded walks of neighbouring levels, sign flips
    /// and jumps (the seed is printed on failure).
    #[test]
    fn level_count_is_the_number_of_distinct_levels() {
        for seed in 1..=50u64 {
            let mut rng = seed;
            let mut next = |n: u64| {
                rng = rng
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                (rng >> 33) % n
            };
            let (mut acc, mut set) = (Acc::default(), std::collections::BTreeSet::new());
            let mut level = 100i64;
            for _ in 0..2000 {
                level = match next(10) {
                    0 => next(200) as i64,
                    r => (level + r as i64 % 5 - 2).clamp(0, 199),
                };
                let bits = (1.5f32 * 0.9f32.powi(level as i32)).to_bits();
                acc.see_level(bits);
                set.insert(bits);
                assert_eq!(acc.levels.len(), set.len(), "seed {seed}");
            }
        }
    }

    #[test]
    fn definitions_of_scenario_md() -> consensus_plot::error::Result<()> {
        let s = feed(&[1.0, 0.2, 0.8, 0.1, 0.1])?;
        assert_eq!(
            s.settling_time,
            Some(3.0),
            "t_(k+1) of the last sample outside"
        );
        assert_eq!(
            s.max_error_after_predefined_time,
            Some(0.8),
            "over t_k >= 2"
        );
        let a = &s.agents[0];
        assert!((a.iae - 2.2).abs() < 1e-12);
        assert!((a.u_energy - 5.0 * 2.0 * 4.0).abs() < 1e-9);
        assert_eq!(
            a.quantizer_changes,
            2 * 3,
            "0->0.5, 0.5->0.7, 0.7->0.5 on both actuators"
        );
        assert_eq!(a.levels_used, Some(2));
        assert_eq!((a.final_mu, a.final_xi, a.final_lambda), (1.0, 2.0, 3.0));
        let never = feed(&[1.0, 1.0, 1.0, 1.0, 1.0])?;
        assert_eq!(never.settling_time, None, "last sample outside the band");
        let always = feed(&[0.1, 0.1, 0.1, 0.1, 0.1])?;
        assert_eq!(always.settling_time, Some(0.0));
        Ok(())
    }

    #[test]
    fn settling_time_needs_the_dwell_inside_the_band_and_is_never_the_last_sample() -> Result<()> {
        let late = [1.0, 1.0, 1.0, 0.1, 0.1];
        assert_eq!(
            feed(&late)?.settling_time,
            Some(3.0),
            "t_3 to t_4 spans 1 s"
        );
        let default_dwell = feed_with(&late, "")?;
        assert_eq!(
            default_dwell.settling_time, None,
            "default dwell 2Ts = 2 s, only 1 s inside"
        );
        let last = [1.0, 1.0, 1.0, 1.0, 0.1];
        assert_eq!(feed(&last)?.settling_time, None, "only t_4 inside");
        let tiny = feed_with(&last, "[metrics]\nsettle_dwell = 1e-9")?;
        assert_eq!(tiny.settling_time, None, "a single sample spans no time");
        Ok(())
    }

    #[test]
    fn window_figures_cover_the_samples_between_from_and_to() -> Result<()> {
        let windows =
            "[[metrics.window]]\nname = \"peak\"\nfrom = 1.0\nto = 3.0\nkind = \"max_error\"\n\
                       [[metrics.window]]\nname = \"late iae\"\nfrom = 2.5\nkind = \"iae\"\n\
                       [[metrics.window]]\nname = \"effort\"\nto = 1.0\nkind = \"energy\"\n\
                       [[metrics.window]]\nname = \"after\"\nfrom = 9.0\nkind = \"iae\"";
        let s = feed_with(&[1.0, 0.2, 0.8, 0.1, 0.3], windows)?;
        assert_eq!(s.window("peak"), Some(0.8), "t = 1, 2, 3");
        let late = s.window("late iae").unwrap_or(f64::NAN);
        assert!((late - 0.4).abs() < 1e-12, "t = 3, 4: {late}");
        assert_eq!(
            s.window("effort"),
            Some(2.0 * 4.0 * 2.0),
            "t = 0, 1; u = 2 on two actuators"
        );
        assert_eq!(s.window("after"), None, "no sample after t_end");
        assert_eq!(s.windows[1].to, 5.0, "an open window ends at t_end");
        assert_eq!(s.units.get("windows.value"), Some(&"windows.unit"));
        Ok(())
    }

    #[test]
    fn bad_windows_and_dwell_name_their_key() {
        for (extra, key) in [
            ("[metrics]\nsettle_dwell = 0.0", "metrics.settle_dwell"),
            (
                "[[metrics.window]]\nname = \"a\"\nkind = \"iae\"\n[[metrics.window]]\nname = \"a\"\nkind = \"iae\"",
                "metrics.window[2].name",
            ),
            (
                "[[metrics.window]]\nname = \"a\"\nfrom = 2.0\nto = 1.0\nkind = \"iae\"",
                "metrics.window[1].to",
            ),
            (
                "[[metrics.window]]\nname = \"a\"\nfrom = -1.0\nkind = \"iae\"",
                "metrics.window[1].from",
            ),
        ] {
            match feed_with(&[0.0; 5], extra) {
                Err(e) => assert!(e.to_string().contains(key), "{key}: {e}"),
                Ok(_) => panic!("{key} accepted"),
            }
        }
    }
}
