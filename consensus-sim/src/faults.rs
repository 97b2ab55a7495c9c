//! Actuator faults `q^f = ϱ(t) q(u) + ū(t)` (LAW §7, the paper's eq. 3) on repeating windows,
//! with the Assumption 4 check: never all actuators of an agent in total loss at once.

use std::{fmt, sync::Arc};

use serde::{de, Deserialize, Deserializer, Serialize, Serializer};

use consensus_plot::error::{Error, Result};

/// `[faults]`: actuator fault rules (LAW §7); the default is LAW §8's schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaultsSpec {
    /// Off: every actuator healthy.
    pub enabled: bool,
    /// The rules (`[[faults.rule]]`).
    #[serde(default = "default_rules")]
    pub rule: Vec<FaultRule>,
    /// Sensor faults (`[[faults.sensor]]`): an agent's controller reads a NaN state on
    /// `[from, until)` (the plant is not affected).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sensor: Vec<SensorFault>,
    /// Run schedules with all `m` actuators of an agent in total loss at once (beyond
    /// Assumption 4; for fault campaigns). Default false: such a schedule is rejected.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub beyond_assumption4: bool,
}

impl Default for FaultsSpec {
    fn default() -> Self {
        Self {
            enabled: true,
            rule: default_rules(),
            sensor: Vec::new(),
            beyond_assumption4: false,
        }
    }
}

impl FaultsSpec {
    /// The schedule of the rules for `agents` agents with `m` actuators (healthy when off)
    /// and the sensor windows checked; Assumption 4 over `[0, t_end)` unless
    /// `beyond_assumption4`.
    pub fn schedule(&self, agents: usize, m: usize, t_end: f64) -> Result<FaultSchedule> {
        let faults = if !self.enabled {
            FaultSchedule::healthy(agents, m)
        } else if self.beyond_assumption4 {
            FaultSchedule::compile(&self.rule, agents, m)?
        } else {
            FaultSchedule::from_rules(&self.rule, agents, m, t_end)?
        };
        for (j, f) in self.sensor.iter().enumerate() {
            let key = |k: &str| format!("faults.sensor[{}].{k}", j + 1);
            if f.agent < 1 || f.agent as usize > agents {
                return Err(Error::invalid(
                    key("agent"),
                    format!("agent {} out of range 1..={agents}", f.agent),
                ));
            }
            if !(f.from.is_finite() && f.until.is_finite() && f.from < f.until) {
                return Err(Error::invalid(
                    key("until"),
                    format!("need finite from < until (got {} .. {})", f.from, f.until),
                ));
            }
        }
        Ok(faults)
    }

    /// The default rules (LAW §8, for m = 2) keep only those whose actuator the plant has: a
    /// custom plant with fewer actuators gets no rule it did not write that it cannot take.
    pub fn fit_default_rules(&mut self, m: usize) {
        if self.rule == default_rules() {
            self.rule
                .retain(|r| usize::try_from(r.actuator).is_ok_and(|a| a <= m));
        }
    }

    /// The sensor windows in force as (0-based agent, from, until); none when faults are off.
    pub fn sensor_windows(&self) -> Vec<(usize, f64, f64)> {
        if !self.enabled {
            return Vec::new();
        }
        self.sensor
            .iter()
            .map(|f| ((f.agent - 1) as usize, f.from, f.until))
            .collect()
    }
}

/// One `[[faults.sensor]]` window: agent `agent` (1-based) reads NaN on `[from, until)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorFault {
    /// 1-based agent.
    pub agent: i64,
    /// Start \[s\].
    pub from: f64,
    /// End \[s\], exclusive.
    pub until: f64,
}

fn default_rules() -> Vec<FaultRule> {
    vec![
        FaultRule {
            kind: FaultKind::Partial,
            gain: Some(0.5),
            ..FaultRule::window(1)
        },
        FaultRule {
            kind: FaultKind::Stuck,
            bias: Some(0.0),
            amplitude: Some(1.0),
            omega: Some(1.0),
            ..FaultRule::window(2)
        },
    ]
}

/// Which agents a rule applies to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Agents {
    /// Every agent.
    All,
    /// These agents (1-based).
    List(Vec<i64>),
}

impl Serialize for Agents {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            Self::All => s.serialize_str("all"),
            Self::List(v) => v.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for Agents {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> de::Visitor<'de> for V {
            type Value = Agents;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"all\" or a list of agent numbers")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<Agents, E> {
                if v == "all" {
                    Ok(Agents::All)
                } else {
                    Err(E::invalid_value(de::Unexpected::Str(v), &self))
                }
            }
            fn visit_seq<A: de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<Agents, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element::<i64>()? {
                    v.push(x);
                }
                Ok(Agents::List(v))
            }
        }
        d.deserialize_any(V)
    }
}

/// Fault kinds of LAW §7.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultKind {
    /// `gain · q(u)`, `0 ≤ gain < 1` (`gain = 0` is a total loss).
    Partial,
    /// `bias + amplitude sin(omega t)`, `q(u)` ignored: total loss.
    Stuck,
}

/// One `[[faults.rule]]`: one actuator of some agents on repeating windows
/// `[start + k period, start + k period + length)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultRule {
    /// `"all"` or a list of 1-based agents.
    pub agents: Agents,
    /// 1-based actuator `l`.
    pub actuator: i64,
    /// `partial` or `stuck`.
    pub kind: FaultKind,
    /// Partial: effectiveness `ϱ`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain: Option<f64>,
    /// Stuck: `bias`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias: Option<f64>,
    /// Stuck: sine amplitude.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplitude: Option<f64>,
    /// Stuck: sine angular frequency [rad/s].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega: Option<f64>,
    /// First window start \[s\].
    #[serde(default)]
    pub start: f64,
    /// Repeat period \[s\]; absent: one window.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period: Option<f64>,
    /// Window length \[s\]; absent: until the end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length: Option<f64>,
}

impl FaultRule {
    /// LAW §8's window `[2,4), [6,8), …` on `actuator`, for all agents, partial with no gain.
    fn window(actuator: i64) -> Self {
        Self {
            agents: Agents::All,
            actuator,
            kind: FaultKind::Partial,
            gain: None,
            bias: None,
            amplitude: None,
            omega: None,
            start: 2.0,
            period: Some(4.0),
            length: Some(2.0),
        }
    }
}

/// What an active rule does to its actuator.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Effect {
    /// `ϱ q(u)`.
    Partial(f64),
    /// `bias + amplitude sin(omega t)`.
    Stuck {
        bias: f64,
        amplitude: f64,
        omega: f64,
    },
}

/// One rule as it applies to one actuator of one agent.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Compiled {
    start: f64,
    period: Option<f64>,
    length: Option<f64>,
    effect: Effect,
}

impl Compiled {
    /// Active on `[start + k period, start + k period + length)`.
    #[inline]
    fn active(&self, t: f64) -> bool {
        if t < self.start {
            return false;
        }
        self.phase(t).1
    }

    /// For `t ≥ start`: the period index `k` (0 without a period) and whether `t` lies in
    /// window `k`.
    #[inline]
    fn phase(&self, t: f64) -> (f64, bool) {
        let mut s = t - self.start;
        let mut k = 0.0;
        if let Some(p) = self.period {
            // `rem_euclid` without the slow software `fmod`.
            k = (s / p).floor();
            s -= p * k;
        }
        (k, self.length.is_none_or(|l| s < l))
    }

    /// `Some(a)` when [`Compiled::active`] is `a` at every `t ∈ [lo, hi]`, found from the two
    /// ends alone; `None` when the interval may hold a window edge. Exact, not a tolerance:
    /// every rounded step of `active` (`t − start`, `/ period`, `floor`, `− period·k`) is
    /// monotone in `t`, so within one period index `k` it is true and then false, and two
    /// ends in the same period with the same value settle every instant between them.
    #[inline]
    fn steady(&self, lo: f64, hi: f64) -> Option<bool> {
        if hi < self.start {
            return Some(false);
        }
        if lo < self.start {
            return None;
        }
        let (k_lo, a_lo) = self.phase(lo);
        let (k_hi, a_hi) = self.phase(hi);
        (k_lo == k_hi && a_lo == a_hi).then_some(a_lo)
    }

    /// This rule's part of the effect at `t` (it is active then): eq. (3)'s `ϱ` and `ū`;
    /// `sine` is `sin(ω t)` when computed before.
    #[inline]
    fn act_on(&self, e: &mut ActuatorEffect, t: f64, sine: Option<f64>) {
        match self.effect {
            Effect::Partial(g) => e.gain *= g,
            Effect::Stuck {
                bias,
                amplitude,
                omega,
            } => e.stuck = Some(bias + amplitude * sine.unwrap_or_else(|| stuck_sine(omega, t))),
        }
    }

    /// `ω` of a stuck rule.
    fn omega(&self) -> Option<f64> {
        match self.effect {
            Effect::Stuck { omega, .. } => Some(omega),
            Effect::Partial(_) => None,
        }
    }

    fn total_loss(&self) -> bool {
        matches!(self.effect, Effect::Stuck { .. } | Effect::Partial(0.0))
    }

    /// Window starts in `[0, t_end)`.
    fn starts(&self, t_end: f64) -> Vec<f64> {
        let mut v = Vec::new();
        match self.period {
            None => {
                if self.start >= 0.0 && self.start < t_end {
                    v.push(self.start);
                }
            }
            Some(p) => {
                let k0 = if self.start < 0.0 {
                    (-self.start / p).ceil()
                } else {
                    0.0
                };
                let mut k = k0;
                loop {
                    let s = self.start + k * p;
                    if s >= t_end || v.len() > 1_000_000 {
                        break;
                    }
                    v.push(s);
                    k += 1.0;
                }
            }
        }
        v
    }
}

/// The fault rules of every actuator of every agent.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultSchedule {
    m: usize,
    rules: Vec<Vec<Compiled>>,
}

impl FaultSchedule {
    /// The windows `[a, b)` within `[0, t_end)` in which a rule of actuator `l` (0-based) of
    /// `agent` (0-based) is active, each with whether it is a total loss (for the figures).
    pub fn windows(&self, agent: usize, l: usize, t_end: f64) -> Vec<(f64, f64, bool)> {
        let Some(rules) = self.rules.get(agent * self.m + l) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for c in rules {
            let length = c.length.unwrap_or(f64::INFINITY);
            for s in c.starts(t_end) {
                out.push((s, (s + length).min(t_end), c.total_loss()));
            }
        }
        out
    }

    /// No faults.
    pub fn healthy(agents: usize, m: usize) -> Self {
        Self {
            m,
            rules: vec![Vec::new(); agents * m],
        }
    }

    /// Compiles and checks the scenario's rules (keys, ranges, Assumption 4 over `[0, t_end)`).
    pub fn from_rules(rules: &[FaultRule], agents: usize, m: usize, t_end: f64) -> Result<Self> {
        let s = Self::compile(rules, agents, m)?;
        s.check_assumption4(t_end)?;
        Ok(s)
    }

    /// Compiles and checks the rules (keys, ranges) without the Assumption 4 check
    /// (`faults.beyond_assumption4 = true`: total loss of an agent on purpose).
    pub fn compile(rules: &[FaultRule], agents: usize, m: usize) -> Result<Self> {
        let mut s = Self::healthy(agents, m);
        for (r, rule) in rules.iter().enumerate() {
            let key = |k: &str| format!("faults.rule[{}].{k}", r + 1);
            if rule.actuator < 1 || rule.actuator as usize > m {
                return Err(Error::invalid(
                    key("actuator"),
                    format!(
                        "actuator {} out of range 1..={m} (the model has m = {m} actuators)",
                        rule.actuator
                    ),
                ));
            }
            let l = (rule.actuator - 1) as usize;
            if !rule.start.is_finite() {
                return Err(Error::invalid(key("start"), "must be finite"));
            }
            if let Some(p) = rule.period {
                if !(p.is_finite() && p > 0.0) {
                    return Err(Error::invalid(
                        key("period"),
                        format!("must be > 0 (got {p})"),
                    ));
                }
            }
            if let Some(len) = rule.length {
                if !(len.is_finite() && len > 0.0) {
                    return Err(Error::invalid(
                        key("length"),
                        format!("must be > 0 (got {len})"),
                    ));
                }
            }
            let effect = match rule.kind {
                FaultKind::Partial => {
                    for (k, v) in [
                        ("bias", rule.bias),
                        ("amplitude", rule.amplitude),
                        ("omega", rule.omega),
                    ] {
                        if v.is_some() {
                            return Err(Error::invalid(key(k), "only for kind = \"stuck\""));
                        }
                    }
                    let Some(g) = rule.gain else {
                        return Err(Error::invalid(
                            key("gain"),
                            "required for kind = \"partial\"",
                        ));
                    };
                    if !(0.0..=1.0).contains(&g) {
                        return Err(Error::invalid(
                            key("gain"),
                            format!("must lie in [0, 1] (got {g})"),
                        ));
                    }
                    Effect::Partial(g)
                }
                FaultKind::Stuck => {
                    if rule.gain.is_some() {
                        return Err(Error::invalid(key("gain"), "only for kind = \"partial\""));
                    }
                    let v = |x: Option<f64>, k: &str| -> Result<f64> {
                        let x = x.unwrap_or(0.0);
                        if x.is_finite() {
                            Ok(x)
                        } else {
                            Err(Error::invalid(key(k), "must be finite"))
                        }
                    };
                    Effect::Stuck {
                        bias: v(rule.bias, "bias")?,
                        amplitude: v(rule.amplitude, "amplitude")?,
                        omega: v(rule.omega, "omega")?,
                    }
                }
            };
            let c = Compiled {
                start: rule.start,
                period: rule.period,
                length: rule.length,
                effect,
            };
            let targets: Vec<usize> = match &rule.agents {
                Agents::All => (0..agents).collect(),
                Agents::List(list) => {
                    if list.is_empty() {
                        return Err(Error::invalid(key("agents"), "empty list"));
                    }
                    let mut v = Vec::with_capacity(list.len());
                    for (j, &a) in list.iter().enumerate() {
                        if list[..j].contains(&a) {
                            return Err(Error::invalid(
                                key("agents"),
                                format!("agent {a} listed twice"),
                            ));
                        }
                        if a < 1 || a as usize > agents {
                            return Err(Error::invalid(
                                key("agents"),
                                format!("agent {a} out of range 1..={agents}"),
                            ));
                        }
                        v.push((a - 1) as usize);
                    }
                    v
                }
            };
            for i in targets {
                s.rules[i * m + l].push(c);
            }
        }
        Ok(s)
    }

    /// Rejects a schedule with all `m` actuators of an agent in total loss at some instant.
    fn check_assumption4(&self, t_end: f64) -> Result<()> {
        for i in 0..self.rules.len() / self.m.max(1) {
            let acts = &self.rules[i * self.m..(i + 1) * self.m];
            if !acts.iter().all(|r| r.iter().any(Compiled::total_loss)) {
                continue;
            }
            let all_lost = |t: f64| {
                acts.iter()
                    .all(|r| r.iter().any(|c| c.total_loss() && c.active(t)))
            };
            let mut candidates = vec![0.0];
            for c in acts.iter().flatten().filter(|c| c.total_loss()) {
                candidates.extend(c.starts(t_end));
            }
            if let Some(t) = candidates.into_iter().find(|&t| all_lost(t)) {
                return Err(Error::invalid(
                    "faults.rule",
                    format!(
                        "all {} actuators of agent {} are in total loss at t = {t} \
                         (Assumption 4 allows at most m - 1)",
                        self.m,
                        i + 1
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Whether agent `i` has any rule.
    pub fn any(&self, i: usize) -> bool {
        self.rules[i * self.m..(i + 1) * self.m]
            .iter()
            .any(|r| !r.is_empty())
    }

    /// `q^f` of actuator `l` of agent `i` at time `t` for the quantized command `q`.
    #[inline]
    pub fn apply(&self, i: usize, l: usize, t: f64, q: f64) -> f64 {
        self.effect(i, l, t).on(q)
    }

    /// What the faults of actuator `l` of agent `i` do at time `t` (eq. 3's `ϱ(t)`, `ū(t)`).
    #[inline]
    pub fn effect(&self, i: usize, l: usize, t: f64) -> ActuatorEffect {
        let mut e = ActuatorEffect::HEALTHY;
        for c in &self.rules[i * self.m + l] {
            if c.active(t) {
                c.act_on(&mut e, t, None);
            }
        }
        e
    }

    /// [`FaultSchedule::effect`] of actuator `l` of agent `i` at each of `times`, into `out`
    /// (one per time; the same values). A rule whose window edges miss the span of `times`
    /// is tested once for all of them (`Compiled::steady`) instead of at every instant. A stuck
    /// rule takes `sin(ω t)` from `sines` where it holds them for `times`.
    pub fn effects_at(
        &self,
        i: usize,
        l: usize,
        times: &[f64],
        sines: Sines<'_>,
        out: &mut [ActuatorEffect],
    ) {
        out.fill(ActuatorEffect::HEALTHY);
        let Some(rules) = self.rules.get(i * self.m + l) else {
            return;
        };
        let lo = times.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        // Rules in their order at every instant, as `effect` takes them: the same products.
        for c in rules {
            let table = c.omega().map_or(&[][..], |w| sines.of(w));
            let sine = |n: usize| table.get(n).copied();
            match c.steady(lo, hi) {
                Some(false) => {}
                Some(true) => {
                    for (n, (e, &t)) in out.iter_mut().zip(times).enumerate() {
                        c.act_on(e, t, sine(n));
                    }
                }
                None => {
                    for (n, (e, &t)) in out.iter_mut().zip(times).enumerate() {
                        if c.active(t) {
                            c.act_on(e, t, sine(n));
                        }
                    }
                }
            }
        }
    }

    /// The `ω` of every stuck rule, each once.
    pub fn stuck_omegas(&self) -> Vec<f64> {
        let mut v: Vec<f64> = Vec::new();
        for w in self.rules.iter().flatten().filter_map(Compiled::omega) {
            if !v.iter().any(|x| x.to_bits() == w.to_bits()) {
                v.push(w);
            }
        }
        v
    }

    /// Fault classes: agents with the same rules on every actuator share one, so a stage's
    /// effects are computed once per class. Per agent its class (`None`: healthy), and per class
    /// one agent of it.
    pub fn classes(&self) -> (Vec<Option<usize>>, Vec<usize>) {
        let agents = self.rules.len() / self.m.max(1);
        let rules = |i: usize| &self.rules[i * self.m..(i + 1) * self.m];
        let mut of = Vec::with_capacity(agents);
        let mut members: Vec<usize> = Vec::new();
        for i in 0..agents {
            if !self.any(i) {
                of.push(None);
                continue;
            }
            let c = match members.iter().position(|&r| rules(r) == rules(i)) {
                Some(c) => c,
                None => {
                    members.push(i);
                    members.len() - 1
                }
            };
            of.push(Some(c));
        }
        (of, members)
    }
}

/// `sin(ω t)` of a stuck rule (eq. 3's `ū`), one expression for the rule and its tables, so a
/// table's value is the rule's to the bit.
#[inline]
fn stuck_sine(omega: f64, t: f64) -> f64 {
    (omega * t).sin()
}

/// `sin(ω t)` at a run's stage times for one `ω`, computed once for the runs of a campaign
/// (they share the stage times): `values[k]` at the run's `k`-th distinct stage time.
#[derive(Debug, Clone)]
pub struct SineTable {
    /// `ω` \[rad/s\].
    pub omega: f64,
    /// `sin(ω t_k)`, computed as a stuck rule computes it.
    pub values: Arc<[f64]>,
}

impl SineTable {
    /// The table of `ω` over the stage times `times`.
    pub fn new(omega: f64, times: &[f64]) -> Self {
        Self {
            omega,
            values: times.iter().map(|&t| stuck_sine(omega, t)).collect(),
        }
    }
}

/// The [`SineTable`]s a run has, seen from the stage time `first` on (an index into them).
#[derive(Debug, Clone, Copy, Default)]
pub struct Sines<'a> {
    tables: &'a [SineTable],
    first: usize,
}

impl<'a> Sines<'a> {
    /// `tables` from their `first` entry on.
    pub fn new(tables: &'a [SineTable], first: usize) -> Self {
        Self { tables, first }
    }

    /// `sin(ω t)` from the first stage time on, or nothing (the rule computes them).
    fn of(&self, omega: f64) -> &'a [f64] {
        self.tables
            .iter()
            .find(|s| s.omega.to_bits() == omega.to_bits())
            .and_then(|s| s.values.get(self.first..))
            .unwrap_or_default()
    }
}

/// The faults' effect on one actuator at one instant: `q^f = ū` when stuck, else `ϱ q`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorEffect {
    /// `ϱ(t)`: the product of the active partial-loss gains.
    pub gain: f64,
    /// `ū(t)` of an active stuck rule (the last one listed).
    pub stuck: Option<f64>,
}

impl ActuatorEffect {
    /// No fault: `ϱ = 1`, not stuck.
    pub const HEALTHY: Self = Self {
        gain: 1.0,
        stuck: None,
    };

    /// `q^f` for the quantized command `q`.
    #[inline]
    pub fn on(self, q: f64) -> f64 {
        self.stuck.unwrap_or(self.gain * q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rule(
        actuator: i64,
        kind: FaultKind,
        start: f64,
        period: Option<f64>,
        length: Option<f64>,
    ) -> FaultRule {
        FaultRule {
            agents: Agents::All,
            actuator,
            kind,
            gain: (kind == FaultKind::Partial).then_some(0.5),
            bias: None,
            amplitude: (kind == FaultKind::Stuck).then_some(1.0),
            omega: (kind == FaultKind::Stuck).then_some(1.0),
            start,
            period,
            length,
        }
    }

    /// A stuck rule takes `sin(ω t)` from the table of its `ω`, from the table's `first`
    /// entry on (a table of another `ω`, or one too short, leaves it to the rule).
    #[test]
    fn stuck_rules_read_their_sine_table_from_first_on() -> Result<()> {
        let s =
            FaultSchedule::from_rules(&[rule(1, FaultKind::Stuck, 0.0, None, None)], 1, 2, 10.0)?;
        assert_eq!(s.stuck_omegas(), [1.0]);
        let times = [0.5, 0.75];
        let marked = SineTable {
            omega: 1.0,
            values: Arc::from([9.0, 7.0, 5.0].as_slice()),
        };
        let other = SineTable {
            omega: 2.0,
            values: marked.values.clone(),
        };
        let mut out = [ActuatorEffect::HEALTHY; 2];
        let stuck = |out: &[ActuatorEffect; 2]| out.map(|e| e.stuck);
        s.effects_at(
            0,
            0,
            &times,
            Sines::new(std::slice::from_ref(&marked), 1),
            &mut out,
        );
        assert_eq!(stuck(&out), [Some(7.0), Some(5.0)]);
        s.effects_at(
            0,
            0,
            &times,
            Sines::new(std::slice::from_ref(&marked), 2),
            &mut out,
        );
        assert_eq!(stuck(&out), [Some(5.0), Some(0.75f64.sin())]);
        s.effects_at(0, 0, &times, Sines::new(&[other], 0), &mut out);
        assert_eq!(stuck(&out), times.map(|t: f64| Some(t.sin())));
        Ok(())
    }

    #[test]
    fn spec_windows_are_2_to_4_6_to_8() -> Result<()> {
        let r = [
            rule(1, FaultKind::Partial, 2.0, Some(4.0), Some(2.0)),
            rule(2, FaultKind::Stuck, 2.0, Some(4.0), Some(2.0)),
        ];
        let s = FaultSchedule::from_rules(&r, 4, 2, 10.0)?;
        for (t, active) in [
            (1.999, false),
            (2.0, true),
            (3.999, true),
            (4.0, false),
            (6.5, true),
            (8.0, false),
        ] {
            assert_eq!(s.apply(3, 0, t, 1.0) == 0.5, active, "t = {t}");
            let stuck = s.apply(3, 1, t, 7.0);
            assert_eq!(stuck == t.sin(), active, "t = {t}");
        }
        Ok(())
    }

    #[test]
    fn all_actuators_in_total_loss_at_once_is_rejected() {
        let r = [
            rule(1, FaultKind::Stuck, 2.0, Some(4.0), Some(2.0)),
            rule(2, FaultKind::Stuck, 3.5, Some(10.0), Some(0.1)),
        ];
        match FaultSchedule::from_rules(&r, 2, 2, 10.0) {
            Err(e) => assert!(e.to_string().contains("t = 3.5"), "{e}"),
            Ok(_) => panic!("both actuators stuck on [3.5, 3.6) must be rejected"),
        }
        // Disjoint windows are allowed (total loss on alternating actuators).
        let ok = [
            rule(1, FaultKind::Stuck, 0.0, Some(2.0), Some(1.0)),
            rule(2, FaultKind::Stuck, 1.0, Some(2.0), Some(1.0)),
        ];
        assert!(FaultSchedule::from_rules(&ok, 2, 2, 10.0).is_ok());
        // A window beyond t_end does not count.
        let late = [
            rule(1, FaultKind::Stuck, 0.0, None, None),
            rule(2, FaultKind::Stuck, 20.0, None, None),
        ];
        assert!(FaultSchedule::from_rules(&late, 2, 2, 10.0).is_ok());
    }
}
