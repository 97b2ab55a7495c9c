//! The `[node]` section: the firmware nodes' identifier plan, heartbeat and safe-state
//! supervision (`kind = "can"` and `"pil"`; no effect on `"ideal"`), its checks, and the
//! [`agent_node::NodeConfig`] fields it gives.

use agent_node::{
    wire::IdPlanError, IdPlan, NeighbourLoss, NodeConfig, SafePolicy, SupervisorConfig,
};
use serde::{Deserialize, Serialize};

use consensus_plot::error::{Error, Result};

/// `node.safe_state.policy` and `node.safe_state.sensor_policy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PolicyName {
    /// Closed loop: the controller tracks the leader's last valid value (CiA 402 halt).
    #[default]
    HoldPosition,
    /// Closed loop: the controller tracks the agent's own motion brought to rest at
    /// `stop_decel` (CiA 402 quick stop).
    Stop,
    /// Open loop: keep the last command.
    Hold,
    /// Open loop: ramp the commands to zero at `ramp_rate`.
    Ramp,
    /// Open loop: zero.
    Off,
}

impl PolicyName {
    /// The name in a scenario file.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::HoldPosition => "hold-position",
            Self::Stop => "stop",
            Self::Hold => "hold",
            Self::Ramp => "ramp",
            Self::Off => "off",
        }
    }

    /// The controller stops stepping under this policy.
    pub fn is_open_loop(self) -> bool {
        matches!(self, Self::Hold | Self::Ramp | Self::Off)
    }
}

/// `node.safe_state.sensor_policy`'s default: the command the controller itself holds on a
/// non-finite state.
fn default_sensor_policy() -> PolicyName {
    PolicyName::Hold
}

fn is_default_sensor_policy(p: &PolicyName) -> bool {
    *p == default_sensor_policy()
}

/// `node.safe_state.neighbour_loss`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LossName {
    /// Every neighbour silent.
    #[default]
    All,
    /// Any neighbour silent.
    Any,
}

/// `[node.safe_state]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafeStateSpec {
    /// `"hold-position"` (default), `"stop"`, `"hold"`, `"ramp"` or `"off"`.
    pub policy: PolicyName,
    /// Units of command per second (a `"ramp"` policy or sensor policy only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ramp_rate: Option<f64>,
    /// Deceleration of the stop reference [units of y / s²] (`policy = "stop"` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stop_decel: Option<f64>,
    /// The open-loop policy while the sensor is lost: `"hold"` (default), `"ramp"`, `"off"`.
    #[serde(
        default = "default_sensor_policy",
        skip_serializing_if = "is_default_sensor_policy"
    )]
    pub sensor_policy: PolicyName,
    /// Leader silent longer than this is a loss \[s\]; absent: not supervised.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub leader_timeout: Option<f64>,
    /// Neighbour silence longer than this is a loss \[s\]; absent: not supervised.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub neighbour_timeout: Option<f64>,
    /// `"all"` or `"any"` neighbour.
    pub neighbour_loss: LossName,
    /// Sensor invalid longer than this is a loss \[s\]; absent: not supervised.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_timeout: Option<f64>,
    /// Every supervised source healthy this long before leaving the safe state \[s\].
    pub recover_dwell: f64,
    /// Speed at which returning values re-enter without `[safety]` [units of y / s]; absent: 1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reentry_rate: Option<f64>,
}

impl Default for SafeStateSpec {
    fn default() -> Self {
        Self {
            policy: PolicyName::default(),
            ramp_rate: None,
            stop_decel: None,
            sensor_policy: default_sensor_policy(),
            leader_timeout: None,
            neighbour_timeout: None,
            neighbour_loss: LossName::default(),
            sensor_timeout: None,
            recover_dwell: 0.0,
            reentry_rate: None,
        }
    }
}

impl SafeStateSpec {
    /// Nothing supervised.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// `[node]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NodeSpec {
    /// Identifier of the leader's value frames; agent `i` sends at `id_base + i`.
    pub id_base: i64,
    /// Agent `i`'s heartbeat identifier is `heartbeat_id_base + i`.
    pub heartbeat_id_base: i64,
    /// Heartbeat period \[s\]; 0: no heartbeat.
    pub heartbeat_period: f64,
    /// `kind = "pil"`: sample periods after the deadline of its last step that ended in time
    /// (and half a period more) at which the node firmware's watchdog resets it; 0: no
    /// watchdog.
    pub watchdog_periods: i64,
    /// `[node.safe_state]`.
    #[serde(skip_serializing_if = "SafeStateSpec::is_default")]
    pub safe_state: SafeStateSpec,
}

impl Default for NodeSpec {
    fn default() -> Self {
        Self {
            id_base: i64::from(IdPlan::DEFAULT.value_base()),
            heartbeat_id_base: IdPlan::DEFAULT.heartbeat_base().map_or(0x780, i64::from),
            heartbeat_period: 0.0,
            watchdog_periods: i64::from(agent_node::link::DEFAULT_WATCHDOG_PERIODS),
            safe_state: SafeStateSpec::default(),
        }
    }
}

impl NodeSpec {
    /// The default section: left out of the resolved scenario.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// Longest timeout, period or dwell accepted [s].
const MAX_SECONDS: f64 = 1e6;

fn seconds_to_us(s: f64) -> u64 {
    (s * 1e6).round() as u64
}

fn timeout(v: Option<f64>, key: &str) -> Result<Option<u64>> {
    match v {
        None => Ok(None),
        Some(s) if (1e-6..=MAX_SECONDS).contains(&s) => Ok(Some(seconds_to_us(s))),
        Some(s) => Err(Error::invalid(
            key,
            format!("must be in [1e-6, {MAX_SECONDS:e}] s (got {s})"),
        )),
    }
}

fn identifier(v: i64, key: &str) -> Result<u16> {
    u16::try_from(v)
        .ok()
        .filter(|&id| id <= agent_node::wire::MAX_STD_ID)
        .ok_or_else(|| {
            Error::invalid(
                key,
                format!("must be an 11-bit identifier in 0..=0x7FF (got {v})"),
            )
        })
}

/// The identifier plan of `spec` for `agents` agents.
fn plan(spec: &NodeSpec, agents: usize) -> Result<IdPlan> {
    let base = identifier(spec.id_base, "node.id_base")?;
    let hb = identifier(spec.heartbeat_id_base, "node.heartbeat_id_base")?;
    let n = u8::try_from(agents).map_err(|_| {
        Error::invalid(
            "node.id_base",
            format!("an identifier plan carries at most 255 agents (got {agents})"),
        )
    })?;
    let heartbeat = (spec.heartbeat_period > 0.0).then_some(hb);
    IdPlan::new(base, heartbeat, n).map_err(|e| {
        let key = match e {
            IdPlanError::HeartbeatRange | IdPlanError::Overlap => "node.heartbeat_id_base",
            _ => "node.id_base",
        };
        Error::invalid(
            key,
            format!(
                "{e}: value frames at {base:#05x}..={:#05x}{}",
                u32::from(base) + u32::from(n),
                heartbeat.map_or(String::new(), |hb| format!(
                    ", heartbeats at {:#05x}..={:#05x}",
                    u32::from(hb) + 1,
                    u32::from(hb) + u32::from(n)
                ))
            ),
        )
    })
}

/// A positive, finite `f32` rate under `key`, needed by `policy` (`None`: absent).
fn rate(v: Option<f64>, key: &str, needed: bool, policy: &str, unit: &str) -> Result<Option<f32>> {
    match (v, needed) {
        (Some(r), true) if r.is_finite() && r > 0.0 && r <= f64::from(f32::MAX) => {
            Ok(Some(r as f32))
        }
        (Some(r), true) => Err(Error::invalid(
            key,
            format!("must be finite and > 0 (got {r})"),
        )),
        (None, true) => Err(Error::invalid(
            key,
            format!("needed with {policy} ({unit})"),
        )),
        (Some(_), false) => Err(Error::invalid(key, format!("only for {policy}"))),
        (None, false) => Ok(None),
    }
}

/// The supervision of `[node.safe_state]`.
fn supervisor(s: &SafeStateSpec) -> Result<SupervisorConfig> {
    if !s.sensor_policy.is_open_loop() {
        return Err(Error::invalid(
            "node.safe_state.sensor_policy",
            format!(
                "must be \"hold\", \"ramp\" or \"off\" (got \"{}\"): without a sensor there \
                 is no loop to close",
                s.sensor_policy.as_str()
            ),
        ));
    }
    let uses_ramp = s.policy == PolicyName::Ramp || s.sensor_policy == PolicyName::Ramp;
    let ramp = rate(
        s.ramp_rate,
        "node.safe_state.ramp_rate",
        uses_ramp,
        "policy or sensor_policy = \"ramp\"",
        "command units per second",
    )?;
    let decel = rate(
        s.stop_decel,
        "node.safe_state.stop_decel",
        s.policy == PolicyName::Stop,
        "policy = \"stop\"",
        "units of y per second squared",
    )?;
    let policy = |name: PolicyName| match name {
        PolicyName::HoldPosition => SafePolicy::HoldPosition,
        PolicyName::Stop => SafePolicy::Stop {
            decel: decel.unwrap_or(f32::INFINITY),
        },
        PolicyName::Hold => SafePolicy::Hold,
        PolicyName::Ramp => SafePolicy::Ramp {
            rate: ramp.unwrap_or(f32::INFINITY),
        },
        PolicyName::Off => SafePolicy::Off,
    };
    let (policy, sensor_policy) = (policy(s.policy), policy(s.sensor_policy));
    if !(s.recover_dwell.is_finite() && (0.0..=MAX_SECONDS).contains(&s.recover_dwell)) {
        return Err(Error::invalid(
            "node.safe_state.recover_dwell",
            format!(
                "must be in [0, {MAX_SECONDS:e}] s (got {})",
                s.recover_dwell
            ),
        ));
    }
    Ok(SupervisorConfig {
        policy,
        leader_timeout_us: timeout(s.leader_timeout, "node.safe_state.leader_timeout")?,
        neighbour_timeout_us: timeout(s.neighbour_timeout, "node.safe_state.neighbour_timeout")?,
        neighbour_loss: match s.neighbour_loss {
            LossName::All => NeighbourLoss::All,
            LossName::Any => NeighbourLoss::Any,
        },
        sensor_timeout_us: timeout(s.sensor_timeout, "node.safe_state.sensor_timeout")?,
        recover_dwell_us: seconds_to_us(s.recover_dwell),
        sensor_policy,
        reentry_rate: match s.reentry_rate {
            None => SupervisorConfig::OFF.reentry_rate,
            Some(r) if r > 0.0 => r as f32,
            Some(r) => {
                return Err(Error::invalid(
                    "node.safe_state.reentry_rate",
                    format!("must be > 0 units of y per s, inf for at once (got {r})"),
                ))
            }
        },
    })
}

fn heartbeat_period(spec: &NodeSpec) -> Result<u64> {
    let p = spec.heartbeat_period;
    if p == 0.0 {
        return Ok(0);
    }
    if !(1e-6..=MAX_SECONDS).contains(&p) {
        return Err(Error::invalid(
            "node.heartbeat_period",
            format!("must be 0 (off) or in [1e-6, {MAX_SECONDS:e}] s (got {p})"),
        ));
    }
    Ok(seconds_to_us(p))
}

/// Largest `node.watchdog_periods`.
pub const MAX_WATCHDOG_PERIODS: i64 = 100_000;

/// Longest watchdog timeout of the emulated board \[s\]: 2³² counts of its 25 MHz clock.
pub const MAX_WATCHDOG_SECONDS: f64 = 4_294_967_295.0 / 25e6;

/// `node.watchdog_periods` of the validated `spec` (0: no watchdog), checked against the
/// sample period `h` when given: the longest timeout, `watchdog_periods + 1.5` periods from
/// the end of a step, must fit the emulated watchdog's counter.
pub fn watchdog_periods(spec: &NodeSpec, h: Option<f64>) -> Result<u32> {
    let n = spec.watchdog_periods;
    let periods = u32::try_from(n)
        .ok()
        .filter(|_| n <= MAX_WATCHDOG_PERIODS)
        .ok_or_else(|| {
            Error::invalid(
                "node.watchdog_periods",
                format!("must be 0 (no watchdog) or in 1..={MAX_WATCHDOG_PERIODS} (got {n})"),
            )
        })?;
    if let Some(h) = h {
        let longest = (f64::from(periods) + 2.0) * h;
        if periods > 0 && longest > MAX_WATCHDOG_SECONDS {
            return Err(Error::invalid(
                "node.watchdog_periods",
                format!(
                    "(watchdog_periods + 2) h = {longest} s exceeds the emulated watchdog's \
                     longest timeout, {MAX_WATCHDOG_SECONDS:.1} s (2^32 counts at 25 MHz)"
                ),
            ));
        }
    }
    Ok(periods)
}

/// The check of `node.watchdog_periods` against the sample period `h` (a value out of range is
/// [`validate`]'s to report).
pub fn check_watchdog_timeout(spec: &NodeSpec, h: f64) -> Result<()> {
    if watchdog_periods(spec, None).is_err() {
        return Ok(());
    }
    watchdog_periods(spec, Some(h)).map(|_| ())
}

/// Checks `[node]` for `agents` agents (every key, whatever the network kind; a bus carries
/// at most 255 agents, which `[network]`'s check reports, so a larger group is checked as 255).
pub fn validate(spec: &NodeSpec, agents: usize) -> Result<()> {
    let agents = agents.min(usize::from(u8::MAX));
    watchdog_periods(spec, None)?;
    configure(spec, agents, &mut NodeConfig::<0>::new(1, [], 1))
}

/// Writes the identifier plan, heartbeat period and supervision of the validated `spec` for
/// `agents` agents into `cfg`.
pub fn configure<const K: usize>(
    spec: &NodeSpec,
    agents: usize,
    cfg: &mut NodeConfig<K>,
) -> Result<()> {
    cfg.heartbeat_period_us = heartbeat_period(spec)?;
    cfg.ids = plan(spec, agents)?;
    cfg.supervisor = supervisor(&spec.safe_state)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(spec: &NodeSpec) -> String {
        validate(spec, 4).expect_err("invalid").to_string()
    }

    #[test]
    fn default_section_gives_the_default_plan_without_heartbeat_or_supervision() {
        let mut cfg = NodeConfig::<0>::new(1, [], 1);
        configure(&NodeSpec::default(), 4, &mut cfg).expect("valid");
        assert_eq!(cfg.ids.value_base(), 0x101);
        assert_eq!(cfg.ids.heartbeat_base(), None);
        assert_eq!(cfg.heartbeat_period_us, 0);
        assert_eq!(cfg.supervisor, SupervisorConfig::OFF);
    }

    #[test]
    fn bad_keys_are_named() {
        let cases: [(NodeSpec, &str); 12] = [
            (
                NodeSpec {
                    safe_state: SafeStateSpec {
                        policy: PolicyName::Stop,
                        ..SafeStateSpec::default()
                    },
                    ..NodeSpec::default()
                },
                "node.safe_state.stop_decel",
            ),
            (
                NodeSpec {
                    safe_state: SafeStateSpec {
                        policy: PolicyName::Stop,
                        stop_decel: Some(0.0),
                        ..SafeStateSpec::default()
                    },
                    ..NodeSpec::default()
                },
                "node.safe_state.stop_decel",
            ),
            (
                NodeSpec {
                    safe_state: SafeStateSpec {
                        sensor_policy: PolicyName::HoldPosition,
                        ..SafeStateSpec::default()
                    },
                    ..NodeSpec::default()
                },
                "node.safe_state.sensor_policy",
            ),
            (
                NodeSpec {
                    safe_state: SafeStateSpec {
                        sensor_policy: PolicyName::Ramp,
                        ..SafeStateSpec::default()
                    },
                    ..NodeSpec::default()
                },
                "node.safe_state.ramp_rate",
            ),
            (
                NodeSpec {
                    id_base: 0x800,
                    ..NodeSpec::default()
                },
                "node.id_base",
            ),
            (
                NodeSpec {
                    id_base: 0x7FE,
                    ..NodeSpec::default()
                },
                "node.id_base",
            ),
            (
                NodeSpec {
                    heartbeat_period: 0.1,
                    heartbeat_id_base: 0x100,
                    ..NodeSpec::default()
                },
                "node.heartbeat_id_base",
            ),
            (
                NodeSpec {
                    heartbeat_period: -1.0,
                    ..NodeSpec::default()
                },
                "node.heartbeat_period",
            ),
            (
                NodeSpec {
                    safe_state: SafeStateSpec {
                        policy: PolicyName::Ramp,
                        ..SafeStateSpec::default()
                    },
                    ..NodeSpec::default()
                },
                "node.safe_state.ramp_rate",
            ),
            (
                NodeSpec {
                    safe_state: SafeStateSpec {
                        ramp_rate: Some(1.0),
                        ..SafeStateSpec::default()
                    },
                    ..NodeSpec::default()
                },
                "node.safe_state.ramp_rate",
            ),
            (
                NodeSpec {
                    safe_state: SafeStateSpec {
                        leader_timeout: Some(0.0),
                        ..SafeStateSpec::default()
                    },
                    ..NodeSpec::default()
                },
                "node.safe_state.leader_timeout",
            ),
            (
                NodeSpec {
                    safe_state: SafeStateSpec {
                        recover_dwell: f64::NAN,
                        ..SafeStateSpec::default()
                    },
                    ..NodeSpec::default()
                },
                "node.safe_state.recover_dwell",
            ),
        ];
        for (spec, key) in cases {
            let m = message(&spec);
            assert!(m.contains(&format!("{key}:")), "{key}: {m}");
        }
    }

    #[test]
    fn watchdog_periods_are_checked_against_the_range_and_the_counter() {
        let with = |n: i64| NodeSpec {
            watchdog_periods: n,
            ..NodeSpec::default()
        };
        assert_eq!(
            watchdog_periods(&NodeSpec::default(), Some(1e-3)).ok(),
            Some(10)
        );
        assert_eq!(watchdog_periods(&with(0), Some(1e6)).ok(), Some(0));
        for bad in [-1, MAX_WATCHDOG_PERIODS + 1] {
            assert!(
                message(&with(bad)).contains("node.watchdog_periods:"),
                "{bad}"
            );
        }
        // 1,000 periods of 0.2 s do not fit 2^32 counts at 25 MHz (171.8 s); of 0.1 s they do.
        let e = watchdog_periods(&with(1000), Some(0.2)).expect_err("too long");
        assert!(e.to_string().contains("node.watchdog_periods:"), "{e}");
        assert!(watchdog_periods(&with(1000), Some(0.1)).is_ok());
    }

    #[test]
    fn a_heartbeat_block_is_checked_only_with_heartbeats_on() {
        let spec = NodeSpec {
            heartbeat_id_base: 0x7FF,
            ..NodeSpec::default()
        };
        assert!(validate(&spec, 4).is_ok());
        let on = NodeSpec {
            heartbeat_period: 0.1,
            ..spec
        };
        assert!(message(&on).contains("heartbeat identifiers"));
    }
}
