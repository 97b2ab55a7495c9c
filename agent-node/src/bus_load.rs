//! How long the frames of this project occupy a CAN bus, worst case, and the share of every
//! sample period that the whole frame set of a bench takes ([`FrameSet::load`]).
//!
//! Payload lengths come from the frame descriptions of [`crate::dbc`] (and the `wire`
//! constants it writes), never from a table of their own.
//!
//! **Classical CAN** (ISO 11898-1, Linux `include/linux/can/length.h` `can_frame_bits()`): a
//! standard frame is SOF + identifier + RTR + IDE + r0 + DLC = 19 header bits (39 extended),
//! `8 n` data bits and the 16-bit CRC field; worst-case stuffing adds one bit per four bits of
//! that region, then ACK slot, ACK delimiter and EOF (9) and the 3-bit intermission follow:
//!
//! ```text
//! bits = (19 + 8 n + 16) + ⌊(19 + 8 n + 16) / 4⌋ + 9 + 3        (n = 4: 95, n = 8: 135)
//! ```
//!
//! **CAN FD** (ISO 11898-1:2015): header SOF + identifier + RRS + IDE + FDF + res + BRS + ESI +
//! DLC = 22 bits (41 extended), `8 n` data bits with `n` rounded up to a valid FD length
//! ([`fd_len`]), dynamic stuffing of `⌊(22 + 8 n − 1) / 4⌋` bits, then the CRC field with fixed
//! stuff bits (stuff count 4 + CRC 17 + delimiter 1 + 6 fixed stuff bits = 28 up to 16 bytes;
//! 4 + 21 + 1 + 7 = 33 above), and the same 9 + 3 bits. With **bit-rate switching** the bits
//! from ESI to the CRC sequence go at the data bit rate; the arbitration bits (SOF..BRS, 17 for
//! a standard frame, with their stuff bits), the CRC delimiter, ACK, EOF and intermission at the
//! nominal rate (the switch back happens inside the CRC delimiter: counted nominal, the worse
//! case).
//!
//! ```
//! use agent_node::bus_load::{frame_bits, Format};
//! assert_eq!(frame_bits(Format::Classical, false, 8, true).total(), 135);
//! let fd = frame_bits(Format::Fd { brs: true }, false, 8, true);
//! assert_eq!((fd.nominal, fd.data), (34, 113));
//! let fd32 = frame_bits(Format::Fd { brs: true }, false, 32, true);
//! assert_eq!((fd32.nominal, fd32.data), (34, 358));
//! ```

use crate::{
    dbc::PLANT_MESSAGES,
    plant_bus::PACKED_SENSOR_AGENTS,
    wire::{HEARTBEAT_LEN, PAYLOAD_LEN},
};

/// How a frame is sent.
///
/// ```
/// use agent_node::bus_load::{frame_bits, Format};
/// // A value frame (4 bytes, 11-bit id), worst-case stuffing: 95 bits classical.
/// assert_eq!(frame_bits(Format::Classical, false, 4, true).total(), 95);
/// let fd = frame_bits(Format::Fd { brs: false }, false, 4, true);
/// assert_eq!(fd.data, 0); // without bit-rate switching everything goes at the nominal rate
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Classical CAN: at most 8 data bytes, one bit rate.
    Classical,
    /// CAN FD: up to 64 data bytes; with `brs` its data phase at the data bit rate.
    Fd {
        /// Bit-rate switching.
        brs: bool,
    },
}

/// The bits of one frame on the wire, by the bit rate they are sent at.
///
/// ```
/// use agent_node::bus_load::{frame_bits, Bitrates, Format};
/// // A heartbeat (8 bytes) on CAN FD with bit-rate switching, 1 Mbit/s and 5 Mbit/s.
/// let b = frame_bits(Format::Fd { brs: true }, false, 8, true);
/// assert_eq!((b.nominal, b.data, b.total()), (34, 113, 147));
/// let ns = b.time_ns(Bitrates { nominal: 1_000_000, data: Some(5_000_000) });
/// assert_eq!(ns, 34_000 + 22_600);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameBits {
    /// Bits at the nominal (arbitration) bit rate, intermission included.
    pub nominal: u32,
    /// Bits at the data bit rate (CAN FD with bit-rate switching; 0 otherwise).
    pub data: u32,
}

impl FrameBits {
    /// Bits on the wire, both phases.
    ///
    /// ```
    /// use agent_node::bus_load::{frame_bits, Format};
    /// assert_eq!(frame_bits(Format::Classical, false, 8, true).total(), 135);
    /// assert_eq!(frame_bits(Format::Classical, false, 8, false).total(), 111); // no stuff bits
    /// ```
    #[must_use]
    pub const fn total(&self) -> u32 {
        self.nominal + self.data
    }

    /// Nanoseconds on a bus at `rates` (rounded up); a data phase without a data bit rate goes
    /// at the nominal rate.
    ///
    /// ```
    /// use agent_node::bus_load::{frame_bits, Bitrates, Format};
    /// // 95 bits at 1 Mbit/s: 95 µs; at 500 kbit/s: 190 µs.
    /// let b = frame_bits(Format::Classical, false, 4, true);
    /// assert_eq!(b.time_ns(Bitrates { nominal: 1_000_000, data: None }), 95_000);
    /// assert_eq!(b.time_ns(Bitrates { nominal: 500_000, data: None }), 190_000);
    /// ```
    #[must_use]
    pub fn time_ns(&self, rates: Bitrates) -> u64 {
        let ns = |bits: u32, rate: u32| {
            (u64::from(bits) * 1_000_000_000).div_ceil(u64::from(rate.max(1)))
        };
        ns(self.nominal, rates.nominal) + ns(self.data, rates.data.unwrap_or(rates.nominal))
    }
}

/// The bit rates of a bus.
///
/// ```
/// use agent_node::bus_load::{Bitrates, Format};
/// let classical = Bitrates { nominal: 1_000_000, data: None };
/// let fd = Bitrates { nominal: 1_000_000, data: Some(5_000_000) };
/// assert_eq!((classical.format(), fd.format()), (Format::Classical, Format::Fd { brs: true }));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bitrates {
    /// Nominal (arbitration) bit rate [bit/s].
    pub nominal: u32,
    /// CAN FD data-phase bit rate [bit/s] with bit-rate switching; `None`: classical CAN.
    pub data: Option<u32>,
}

impl Bitrates {
    /// The format of every frame on this bus: CAN FD with bit-rate switching when a data bit
    /// rate is given, classical otherwise.
    ///
    /// ```
    /// use agent_node::bus_load::{Bitrates, Format};
    /// assert_eq!(Bitrates { nominal: 500_000, data: Some(2_000_000) }.format(), Format::Fd { brs: true });
    /// assert_eq!(Bitrates { nominal: 500_000, data: None }.format(), Format::Classical);
    /// ```
    #[must_use]
    pub const fn format(&self) -> Format {
        match self.data {
            Some(_) => Format::Fd { brs: true },
            None => Format::Classical,
        }
    }
}

/// The CAN FD data length that carries `n` bytes: `n` up to 8, else the next of 12, 16, 20, 24,
/// 32, 48, 64; `None` above 64.
///
/// ```
/// use agent_node::bus_load::fd_len;
/// assert_eq!((fd_len(8), fd_len(9), fd_len(40), fd_len(65)), (Some(8), Some(12), Some(48), None));
/// ```
#[must_use]
pub const fn fd_len(n: usize) -> Option<usize> {
    Some(match n {
        0..=8 => n,
        9..=12 => 12,
        13..=16 => 16,
        17..=20 => 20,
        21..=24 => 24,
        25..=32 => 32,
        33..=48 => 48,
        49..=64 => 64,
        _ => return None,
    })
}

/// Bits on the wire (intermission included) of a data frame with `data_len` bytes (0 for a
/// remote frame; above 8 classical or 64 FD counts as the maximum, the controller sends no
/// more), `extended` for a 29-bit identifier, with worst-case dynamic stuffing if `stuffing`
/// (CAN FD's fixed stuff bits always count), as Linux `can_frame_bits()`.
///
/// ```
/// use agent_node::bus_load::{frame_bits, Format};
/// // An extended (29-bit) identifier costs 20 header bits more, 25 with stuffing.
/// let std = frame_bits(Format::Classical, false, 8, true).total();
/// let ext = frame_bits(Format::Classical, true, 8, true).total();
/// assert_eq!(ext - std, 25);
/// // Beyond 8 bytes a classical controller sends 8.
/// assert_eq!(frame_bits(Format::Classical, false, 12, true), frame_bits(Format::Classical, false, 8, true));
/// ```
#[must_use]
pub const fn frame_bits(
    format: Format,
    extended: bool,
    data_len: usize,
    stuffing: bool,
) -> FrameBits {
    const ACK_EOF: u32 = 9;
    const INTERMISSION: u32 = 3;
    match format {
        Format::Classical => {
            let header: u32 = if extended { 39 } else { 19 };
            let n = if data_len > 8 { 8 } else { data_len as u32 };
            let region = header + 8 * n + 16;
            FrameBits {
                nominal: region + if stuffing { region / 4 } else { 0 } + ACK_EOF + INTERMISSION,
                data: 0,
            }
        }
        Format::Fd { brs } => {
            let (header, arbitration): (u32, u32) = if extended { (41, 36) } else { (22, 17) };
            let n = match fd_len(data_len) {
                Some(n) => n as u32,
                None => 64,
            };
            let dynamic = header + 8 * n;
            let crc_field = if n <= 16 { 28 } else { 33 };
            let stuff = if stuffing { (dynamic - 1) / 4 } else { 0 };
            let total = dynamic + stuff + crc_field + ACK_EOF + INTERMISSION;
            if !brs {
                return FrameBits {
                    nominal: total,
                    data: 0,
                };
            }
            // Arbitration with its stuff bits, CRC delimiter, ACK, EOF, intermission.
            let arbitration_stuff = if stuffing { (arbitration - 1) / 4 } else { 0 };
            let nominal = arbitration + arbitration_stuff + 1 + ACK_EOF + INTERMISSION;
            FrameBits {
                nominal,
                data: total - nominal,
            }
        }
    }
}

/// How the host's sensor frames carry the followers' states (`network.sensor_frames`).
///
/// ```
/// use agent_node::bus_load::{Bitrates, FrameSet, PlantFrames, SensorFrames};
/// // Eight followers on CAN FD: packed sensor frames are fewer than one per agent.
/// let set = |sensor| FrameSet { agents: 8, rates: Bitrates { nominal: 1_000_000, data: Some(5_000_000) },
///     sample_period_us: 1_000, heartbeat_period_us: 0,
///     plant: Some(PlantFrames { sensor, state_period_us: 0 }) };
/// let per_agent = set(SensorFrames::PerAgent).load().kinds[2];
/// let packed = set(SensorFrames::Packed).load().kinds[2];
/// assert_eq!(per_agent.frames, 8.0);
/// assert!(packed.frames < per_agent.frames);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SensorFrames {
    /// One sensor frame per follower (8 bytes: `x_{i,1}`, `x_{i,2}`).
    #[default]
    PerAgent,
    /// One CAN FD frame per [`PACKED_SENSOR_AGENTS`] followers, their 8-byte states in agent
    /// order ([`crate::plant_bus::encode_packed`]).
    Packed,
}

/// The plant's frames on the bus of a bench (`crate::plant_bus`).
///
/// ```
/// use agent_node::bus_load::{Bitrates, FrameSet, PlantFrames, SensorFrames};
/// // A bench: the plant's sensor and command frames every sample add to the nodes' own.
/// let mut set = FrameSet { agents: 4, rates: Bitrates { nominal: 1_000_000, data: None },
///     sample_period_us: 1_000, heartbeat_period_us: 0, plant: None };
/// let alone = set.load().percent();
/// set.plant = Some(PlantFrames { sensor: SensorFrames::PerAgent, state_period_us: 100_000 });
/// assert!(set.load().percent() > alone);
/// assert_eq!(set.load().kinds[3].frames, 4.0); // one command frame per follower
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlantFrames {
    /// How the sensor frames are laid out.
    pub sensor: SensorFrames,
    /// Every node sends its state — its CANopen heartbeat at `0x700 + i`, the NMT state in one
    /// byte — this often \[µs\] (`0x1017`).
    pub state_period_us: u64,
}

/// The frames a scenario puts on one bus.
///
/// ```
/// use agent_node::bus_load::{Bitrates, FrameSet};
/// // The paper's four followers and the leader, 1 Mbit/s classical, h = 1 ms:
/// // five value frames of 95 bits take 475 µs of every 1 ms sample.
/// let set = FrameSet { agents: 4, rates: Bitrates { nominal: 1_000_000, data: None },
///     sample_period_us: 1_000, heartbeat_period_us: 0, plant: None };
/// assert!((set.load().percent() - 47.5).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSet {
    /// Followers (agents `1..=agents`); the leader sends too.
    pub agents: u8,
    /// The bus's bit rates (and so the frames' format).
    pub rates: Bitrates,
    /// Sample period `h` \[µs\]: every sender's value frame once per sample.
    pub sample_period_us: u64,
    /// Heartbeat period of every node \[µs\]; 0: no heartbeats.
    pub heartbeat_period_us: u64,
    /// The plant on the bus (sensor and command frames, the nodes' CANopen heartbeats); `None`:
    /// only the nodes' own.
    pub plant: Option<PlantFrames>,
}

/// One frame kind's share of a sample period.
///
/// ```
/// use agent_node::bus_load::{Bitrates, FrameSet};
/// // Heartbeats every 100 ms at h = 1 ms: 4 nodes × 1/100 frame per sample.
/// let set = FrameSet { agents: 4, rates: Bitrates { nominal: 1_000_000, data: None },
///     sample_period_us: 1_000, heartbeat_period_us: 100_000, plant: None };
/// let hb = set.load().kinds[1];
/// assert_eq!((hb.kind, hb.data_len, hb.bits.total()), ("heartbeat", 8, 135));
/// assert!((hb.frames - 0.04).abs() < 1e-12);
/// assert!((hb.ns_per_sample - 0.04 * 135_000.0).abs() < 1e-6);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KindLoad {
    /// The frame kind (`value`, `heartbeat` (the status PDO), `sensor`, `command`, `state` (the
    /// CANopen heartbeat)).
    pub kind: &'static str,
    /// Frames per sample (periodic kinds slower than `h` count a fraction).
    pub frames: f64,
    /// Data bytes of the largest frame of the kind (FD length).
    pub data_len: usize,
    /// Worst-case bits of that frame.
    pub bits: FrameBits,
    /// Bus time per sample \[ns\].
    pub ns_per_sample: f64,
}

/// The worst-case bus time of a frame set, per sample.
///
/// ```
/// use agent_node::bus_load::{Bitrates, FrameSet, LOAD_WARNING_PERCENT};
/// let set = FrameSet { agents: 4, rates: Bitrates { nominal: 1_000_000, data: None },
///     sample_period_us: 1_000, heartbeat_period_us: 0, plant: None };
/// let load = set.load();
/// assert_eq!(load.kinds[0].kind, "value");
/// assert_eq!(load.period_ns, 1e6);
/// assert!(load.percent() < LOAD_WARNING_PERCENT);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Load {
    /// Value, heartbeat (status PDO), sensor, command, state (CANopen heartbeat) frames (kinds
    /// absent from the set have 0
    /// frames).
    pub kinds: [KindLoad; 5],
    /// Sample period \[ns\].
    pub period_ns: f64,
}

impl Load {
    /// Bus time per sample \[ns\], all kinds.
    ///
    /// ```
    /// use agent_node::bus_load::{Bitrates, FrameSet};
    /// let set = FrameSet { agents: 1, rates: Bitrates { nominal: 1_000_000, data: None },
    ///     sample_period_us: 1_000, heartbeat_period_us: 0, plant: None };
    /// assert_eq!(set.load().busy_ns(), 2.0 * 95_000.0); // the leader's and agent 1's value frame
    /// ```
    #[must_use]
    pub fn busy_ns(&self) -> f64 {
        self.kinds.iter().map(|k| k.ns_per_sample).sum()
    }

    /// Share of the sample period the frames take, in per cent.
    ///
    /// ```
    /// use agent_node::bus_load::{Bitrates, FrameSet};
    /// // At 125 kbit/s the same five value frames no longer fit a 1 ms sample.
    /// let set = FrameSet { agents: 4, rates: Bitrates { nominal: 125_000, data: None },
    ///     sample_period_us: 1_000, heartbeat_period_us: 0, plant: None };
    /// assert!((set.load().percent() - 380.0).abs() < 1e-9);
    /// ```
    #[must_use]
    pub fn percent(&self) -> f64 {
        100.0 * self.busy_ns() / self.period_ns
    }
}

/// Share of the bus above which `host-sim check` warns: room for retransmissions after errors,
/// for frames sent on a change and for the arbitration delay of the lowest-priority frame.
pub const LOAD_WARNING_PERCENT: f64 = 70.0;

impl FrameSet {
    fn kind(&self, kind: &'static str, frames: f64, data_len: usize) -> KindLoad {
        let bits = frame_bits(self.rates.format(), false, data_len, true);
        KindLoad {
            kind,
            frames,
            data_len: match self.rates.format() {
                Format::Classical => data_len,
                Format::Fd { .. } => fd_len(data_len).unwrap_or(64),
            },
            bits,
            ns_per_sample: frames * bits.time_ns(self.rates) as f64,
        }
    }

    /// Frames per sample of something sent every `period_us` (0: never).
    fn per_sample(&self, count: u8, period_us: u64) -> f64 {
        if period_us == 0 {
            return 0.0;
        }
        f64::from(count) * self.sample_period_us as f64 / period_us as f64
    }

    /// The worst-case bus time of every frame kind per sample: the leader's and each follower's
    /// value frame every sample, each node's heartbeat (status PDO) and state (CANopen
    /// heartbeat) at their periods, and on
    /// a bench the sensor frames (one per follower, or packed) and each node's command frame
    /// every sample.
    ///
    /// ```
    /// use agent_node::bus_load::{Bitrates, FrameSet};
    /// // Halving h doubles the share of the bus.
    /// let mut set = FrameSet { agents: 4, rates: Bitrates { nominal: 1_000_000, data: None },
    ///     sample_period_us: 1_000, heartbeat_period_us: 0, plant: None };
    /// let at_1ms = set.load().percent();
    /// set.sample_period_us = 500;
    /// assert!((set.load().percent() - 2.0 * at_1ms).abs() < 1e-9);
    /// ```
    #[must_use]
    pub fn load(&self) -> Load {
        let [sensor, command, state] = &PLANT_MESSAGES;
        let n = self.agents;
        let value = self.kind("value", f64::from(n) + 1.0, PAYLOAD_LEN);
        let heartbeat = self.kind(
            "heartbeat",
            self.per_sample(n, self.heartbeat_period_us),
            HEARTBEAT_LEN,
        );
        let pair = usize::from(sensor.len());
        let (sensors, commands, states) = match self.plant {
            None => (
                self.kind("sensor", 0.0, pair),
                self.kind("command", 0.0, usize::from(command.len())),
                self.kind("state", 0.0, usize::from(state.len())),
            ),
            Some(p) => (
                match p.sensor {
                    SensorFrames::PerAgent => self.kind("sensor", f64::from(n), pair),
                    SensorFrames::Packed => self.packed_sensors(pair),
                },
                self.kind("command", f64::from(n), usize::from(command.len())),
                self.kind(
                    "state",
                    self.per_sample(n, p.state_period_us),
                    usize::from(state.len()),
                ),
            ),
        };
        Load {
            kinds: [value, heartbeat, sensors, commands, states],
            period_ns: self.sample_period_us as f64 * 1e3,
        }
    }

    /// Packed sensor frames: full frames of [`PACKED_SENSOR_AGENTS`] followers and one for the
    /// rest.
    fn packed_sensors(&self, pair: usize) -> KindLoad {
        let per = PACKED_SENSOR_AGENTS.max(1);
        let (full, rest) = (self.agents / per, self.agents % per);
        let mut k = self.kind("sensor", f64::from(full), pair * usize::from(per));
        if rest > 0 {
            let last = self.kind("sensor", 1.0, pair * usize::from(rest));
            k.ns_per_sample += last.ns_per_sample;
            k.frames += 1.0;
            if full == 0 {
                k.data_len = last.data_len;
                k.bits = last.bits;
            }
        }
        k
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MBIT: u32 = 1_000_000;

    fn bench(data: Option<u32>, sensor: SensorFrames) -> FrameSet {
        FrameSet {
            agents: 4,
            rates: Bitrates {
                nominal: MBIT,
                data,
            },
            sample_period_us: 1000,
            heartbeat_period_us: 0,
            plant: Some(PlantFrames {
                sensor,
                state_period_us: 100_000,
            }),
        }
    }

    #[test]
    fn classical_lengths_are_linux_can_frame_bits() {
        // can_frame_bits(false, false, true, true, n) of Linux 6.x.
        for (n, bits) in [(0, 55), (1, 65), (4, 95), (8, 135)] {
            assert_eq!(
                frame_bits(Format::Classical, false, n, true).total(),
                bits,
                "{n} bytes"
            );
        }
        assert_eq!(frame_bits(Format::Classical, true, 8, true).total(), 160);
        assert_eq!(frame_bits(Format::Classical, false, 12, true).total(), 135);
    }

    #[test]
    fn fd_lengths_are_linux_can_frame_bits_split_at_the_bit_rate_switch() {
        // can_frame_bits(true, false, true, true, n): 22 + 8n + ⌊(21 + 8n)/4⌋ + CRC field + 12.
        for (n, bits) in [(0, 67), (8, 147), (12, 187), (32, 392), (64, 712)] {
            let b = frame_bits(Format::Fd { brs: true }, false, n, true);
            assert_eq!(b.total(), bits, "{n} bytes");
            assert_eq!(b.nominal, 34, "{n} bytes");
            assert_eq!(
                frame_bits(Format::Fd { brs: false }, false, n, true).data,
                0
            );
        }
        // A 33-byte payload goes out as 48 bytes.
        assert_eq!(
            frame_bits(Format::Fd { brs: true }, false, 33, true),
            frame_bits(Format::Fd { brs: true }, false, 48, true)
        );
    }

    #[test]
    fn time_uses_each_phase_bit_rate() {
        let b = frame_bits(Format::Fd { brs: true }, false, 8, true);
        let rates = Bitrates {
            nominal: MBIT,
            data: Some(4 * MBIT),
        };
        // 34 µs + 113 / 4 µs.
        assert_eq!(b.time_ns(rates), 34_000 + 28_250);
    }

    #[test]
    fn the_classical_bench_overloads_a_1_mbit_bus() {
        let load = bench(None, SensorFrames::PerAgent).load();
        // 5 × 95 + 8 × 135 µs of 1000, plus 4 CANopen heartbeats (1 byte) of 65 µs every 100
        // samples.
        let expected = 5.0 * 95e3 + 8.0 * 135e3 + 0.04 * 65e3;
        assert!(
            (load.busy_ns() - expected).abs() < 1e-6,
            "{}",
            load.busy_ns()
        );
        assert!(load.percent() > 155.0);
    }

    #[test]
    fn fd_with_packed_sensors_fits_at_4_mbit_data() {
        let load = bench(Some(4 * MBIT), SensorFrames::Packed).load();
        let [_, _, sensor, ..] = load.kinds;
        assert_eq!((sensor.frames, sensor.data_len), (1.0, 32));
        assert!(load.percent() < LOAD_WARNING_PERCENT, "{}", load.percent());
        let unpacked = bench(Some(4 * MBIT), SensorFrames::PerAgent).load();
        assert!(
            unpacked.percent() > LOAD_WARNING_PERCENT,
            "{}",
            unpacked.percent()
        );
    }

    #[test]
    fn packed_sensor_frames_split_after_eight_agents() {
        let mut set = bench(Some(4 * MBIT), SensorFrames::Packed);
        set.agents = 9;
        let [_, _, sensor, ..] = set.load().kinds;
        assert_eq!((sensor.frames, sensor.data_len), (2.0, 64));
        let one = frame_bits(Format::Fd { brs: true }, false, 64, true).time_ns(set.rates)
            + frame_bits(Format::Fd { brs: true }, false, 8, true).time_ns(set.rates);
        assert!((sensor.ns_per_sample - one as f64).abs() < 1e-6);
    }

    #[test]
    fn nodes_without_a_plant_on_the_bus_send_value_frames_and_heartbeats() {
        let mut set = bench(None, SensorFrames::PerAgent);
        set.plant = None;
        set.heartbeat_period_us = 100_000;
        let load = set.load();
        // Docs/NETWORK.md §5: 5 × 95 bits per 1 ms at 1 Mbit/s = 47.5 %, plus heartbeats.
        assert!(
            (load.percent() - (47.5 + 0.04 * 13.5)).abs() < 1e-9,
            "{}",
            load.percent()
        );
    }
}
