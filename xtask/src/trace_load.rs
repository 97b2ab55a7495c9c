//! `cargo xtask trace-load <log> --bitrate B [--data-bitrate D] [--h S]`: the bus time a
//! recorded candump log (`host-sim run … --trace`) took per sample, frame by frame, with the
//! worst-case bit lengths of `agent_node::bus_load` at the given bit rates: the measured
//! counterpart of the load `host-sim check` computes. Classical lines (`ID#DATA`) are timed as
//! classical frames; CAN FD lines (`ID##<flags>DATA`) as FD frames, with bit-rate switching when
//! their flags say so. A sample is one leader value frame (`agent_node::IdPlan::DEFAULT`); frames
//! outside the run's samples (before the first, after the last) are left out. Periodic frames
//! timed by the wall clock (the nodes' CANopen heartbeats) count per sample as often as a run slowed by
//! `network.time_scale` lets them.

use std::fmt::Write as _;

use agent_node::{
    bus_load::{frame_bits, Bitrates, Format},
    plant_bus::Kind,
    wire::{FrameKind, IdPlan, Source},
};

use crate::task::Result;

/// One frame of a candump log line: identifier, data length, CAN FD with or without BRS.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LogFrame {
    pub id: u32,
    pub extended: bool,
    pub len: usize,
    /// `None`: classical; `Some(brs)`: CAN FD.
    pub fd: Option<bool>,
}

/// The frame of a candump log line `(<s>.<µs>) <if> <ID>#<DATA>` or `<ID>##<F><DATA>`; `None`
/// for anything else.
pub fn parse_line(line: &str) -> Option<LogFrame> {
    let frame = line.split_whitespace().nth(2)?;
    let (id, rest) = frame.split_once('#')?;
    let (fd, data) = match rest.strip_prefix('#') {
        Some(r) => {
            let flags = u8::from_str_radix(r.get(..1)?, 16).ok()?;
            (Some(flags & 1 == 1), r.get(1..)?)
        }
        None if rest.starts_with('R') => (None, ""),
        None => (None, rest),
    };
    if data.len() % 2 != 0 {
        return None;
    }
    Some(LogFrame {
        id: u32::from_str_radix(id, 16).ok()?,
        extended: id.len() > 3,
        len: data.len() / 2,
        fd,
    })
}

/// The kind of a frame for the report.
fn kind(f: &LogFrame) -> &'static str {
    if f.extended {
        return "other";
    }
    let raw = f.id as u16;
    match IdPlan::DEFAULT.classify(raw) {
        Some(FrameKind::Value(_)) => return "value",
        Some(FrameKind::Heartbeat(_)) => return "heartbeat",
        None => {}
    }
    match Kind::classify(raw) {
        Some((Kind::Sensor, _)) => "sensor",
        Some((Kind::Command, _)) => "command",
        // The node's state: its CANopen heartbeat (node-ID = agent).
        None if (0x701..=0x77F).contains(&raw) => "state",
        None => "other",
    }
}

/// The stamp of a candump log line, in seconds.
fn stamp(line: &str) -> Option<f64> {
    line.split_whitespace()
        .next()?
        .strip_prefix('(')?
        .strip_suffix(')')?
        .parse()
        .ok()
}

/// Bus time per kind \[ns\], frames per kind, and samples (leader frames) of `text`, counting the
/// frames from the first leader frame up to the next one after the last (the run's samples, not
/// the nodes' start-up or their last periods after the host's last sample).
pub fn measure(text: &str, rates: Bitrates) -> (Vec<(&'static str, u64, f64)>, u64) {
    let mut kinds: Vec<(&'static str, u64, f64)> = Vec::new();
    let leader = IdPlan::DEFAULT.value_id(Source::Leader);
    let is_leader = |f: &LogFrame| !f.extended && Some(f.id as u16) == leader;
    let frames: Vec<(f64, LogFrame)> = text
        .lines()
        .filter_map(|l| Some((stamp(l)?, parse_line(l)?)))
        .collect();
    let leaders: Vec<f64> = frames
        .iter()
        .filter(|f| is_leader(&f.1))
        .map(|f| f.0)
        .collect();
    let (Some(&first), Some(&last)) = (leaders.first(), leaders.last()) else {
        return (kinds, 0);
    };
    let samples = leaders.len() as u64;
    // One period past the last sample: that sample's own frames.
    let period = if samples > 1 {
        (last - first) / (samples - 1) as f64
    } else {
        0.0
    };
    let until = last + period;
    for (t, f) in frames {
        if t < first || t >= until {
            continue;
        }
        let format = match f.fd {
            None => Format::Classical,
            Some(brs) => Format::Fd { brs },
        };
        let ns = frame_bits(format, f.extended, f.len, true).time_ns(rates) as f64;
        let k = kind(&f);
        match kinds.iter_mut().find(|e| e.0 == k) {
            Some(e) => {
                e.1 += 1;
                e.2 += ns;
            }
            None => kinds.push((k, 1, ns)),
        }
    }
    (kinds, samples)
}

pub fn trace_load(args: &[String]) -> Result<()> {
    let mut path = None;
    let (mut nominal, mut data, mut h) = (None, None, 1e-3);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| -> Result<f64> {
            it.next()
                .and_then(|v| v.parse::<f64>().ok())
                .ok_or_else(|| format!("{name} needs a number"))
        };
        match a.as_str() {
            "--bitrate" => nominal = Some(value("--bitrate")? as u32),
            "--data-bitrate" => data = Some(value("--data-bitrate")? as u32),
            "--h" => h = value("--h")?,
            other if path.is_none() && !other.starts_with('-') => path = Some(other.to_owned()),
            other => return Err(format!("unexpected argument `{other}`")),
        }
    }
    let path = path.ok_or("trace-load needs a candump log")?;
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{path}: {e}"))?;
    let rates = Bitrates {
        nominal: nominal.ok_or("trace-load needs --bitrate")?,
        data,
    };
    let (kinds, samples) = measure(&text, rates);
    if samples == 0 {
        return Err(format!(
            "{path}: no leader value frame, so no sample to count"
        ));
    }
    let period_ns = h * 1e9;
    let mut out = String::new();
    let total: f64 = kinds.iter().map(|k| k.2).sum();
    for (k, n, ns) in &kinds {
        let per = ns / samples as f64;
        let _ = writeln!(
            out,
            "{k:<9} {n:>8} frames  {:>7.3} per sample  {:>7.1} µs per sample  {:>5.1} %",
            *n as f64 / samples as f64,
            per * 1e-3,
            100.0 * per / period_ns
        );
    }
    let per = total / samples as f64;
    let _ = writeln!(
        out,
        "total: {samples} samples, {:.1} µs of bus time per sample of {:.1} µs: {:.1} %",
        per * 1e-3,
        period_ns * 1e-3,
        100.0 * per / period_ns
    );
    print!("{out}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candump_lines_give_length_and_format() {
        let f = parse_line("(0.001000) vcan0 101#DEAD0B01").expect("classical");
        assert_eq!((f.id, f.len, f.fd, f.extended), (0x101, 4, None, false));
        let f = parse_line("(0.001000) vcan0 201##1").expect("fd");
        assert_eq!((f.len, f.fd), (0, Some(true)));
        let f = parse_line(&format!("(1.0) vcan0 201##0{}", "00".repeat(32))).expect("fd");
        assert_eq!((f.len, f.fd), (32, Some(false)));
        assert_eq!(parse_line("garbage"), None);
        assert_eq!(parse_line("(1.0) vcan0 101#ABC"), None);
    }

    #[test]
    fn a_sample_of_the_classical_bench_takes_its_worst_case_time() {
        let mut log = String::from("(0.000000) vcan0 101#00000000\n");
        for i in 1..=4 {
            log += &format!("(0.000100) vcan0 {:03X}#00000000\n", 0x101 + i);
            log += &format!("(0.000200) vcan0 {:03X}#0000000000000000\n", 0x200 + i);
            log += &format!("(0.000300) vcan0 {:03X}#0000000000000000\n", 0x300 + i);
        }
        // The next sample's leader frame, and a node's frame after the host stopped.
        log += "(0.001000) vcan0 101#00000000\n(0.003000) vcan0 302#0000000000000000\n";
        let (kinds, samples) = measure(
            &log,
            Bitrates {
                nominal: 1_000_000,
                data: None,
            },
        );
        assert_eq!(samples, 2);
        let total: f64 = kinds.iter().map(|k| k.2).sum();
        assert!((total - (6.0 * 95e3 + 8.0 * 135e3)).abs() < 1e-6, "{total}");
    }
}
