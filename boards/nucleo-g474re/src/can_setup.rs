//! What the FDCAN1 set-up writes, as values: the nominal bit timing (`FDCAN_NBTP`), the
//! standard acceptance filter elements in message RAM (`SFT`/`SFEC`/`SFID1`/`SFID2`) and the
//! global filter (`FDCAN_RXGFC`), RM0440 §44. The firmware hands the same values to the
//! `fdcan` crate, which writes them; the host tests check the words against the manual.

use agent_node::{
    canopen::{sdo_rx_id, NMT_ID},
    plant_bus,
    wire::Source,
    NodeConfig,
};

/// FDCAN kernel clock: the 24 MHz HSE (`RCC_CCIPR.FDCANSEL` = HSE, the reset value).
pub const KERNEL_HZ: u32 = 24_000_000;

/// Nominal bit timing in time quanta: `bit = (1 + seg1 + seg2) · prescaler / f_kernel`, the
/// sample point at `(1 + seg1) / (1 + seg1 + seg2)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BitTiming {
    /// Bit-rate prescaler (1..=512).
    pub prescaler: u16,
    /// Time segment before the sample point, propagation included (1..=255 here; the
    /// register takes 256).
    pub seg1: u8,
    /// Time segment after the sample point (1..=128).
    pub seg2: u8,
    /// Synchronisation jump width (1..=128, ≤ `seg2`).
    pub sjw: u8,
}

/// 1 Mbit/s from the 24 MHz kernel clock: prescaler 1, 24 quanta (1 + 19 + 4), sample point
/// 20/24 = 83.3 %, SJW 4 (CiA 601-3 recommends 75–90 % at 1 Mbit/s).
pub const BIT_TIMING: BitTiming = BitTiming {
    prescaler: 1,
    seg1: 19,
    seg2: 4,
    sjw: 4,
};

const _: () = assert!(
    BIT_TIMING.prescaler > 0
        && BIT_TIMING.seg1 > 0
        && BIT_TIMING.seg2 > 0
        && BIT_TIMING.sjw > 0
        && BIT_TIMING.sjw <= BIT_TIMING.seg2,
    "every field at least 1, SJW no longer than the phase after the sample point"
);

impl BitTiming {
    /// Time quanta per bit.
    pub const fn quanta(&self) -> u32 {
        1 + self.seg1 as u32 + self.seg2 as u32
    }

    /// Bits per second at kernel clock `kernel_hz`.
    pub const fn bit_rate(&self, kernel_hz: u32) -> u32 {
        kernel_hz / (self.prescaler as u32 * self.quanta())
    }

    /// Sample point in per mille of the bit.
    pub const fn sample_point_permille(&self) -> u32 {
        (1 + self.seg1 as u32) * 1_000 / self.quanta()
    }

    /// `FDCAN_NBTP`: `NSJW[31:25]`, `NBRP[24:16]`, `NTSEG1[15:8]`, `NTSEG2[6:0]`, each field
    /// holding its value minus one.
    pub const fn nbtp(&self) -> u32 {
        ((self.sjw as u32 - 1) << 25)
            | ((self.prescaler as u32 - 1) << 16)
            | ((self.seg1 as u32 - 1) << 8)
            | (self.seg2 as u32 - 1)
    }
}

/// The standard filter slots the set-up fills: the CANopen device's NMT and SDO requests, the
/// leader, this agent, one per neighbour, and on the bench the agent's sensor frame.
pub const SLOTS: usize = 8;

/// One acceptance filter: the frames with these 11-bit identifiers go to FIFO 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Accept {
    /// One identifier.
    Single(u16),
    /// Two identifiers (a value and a heartbeat).
    Dual(u16, u16),
}

impl Accept {
    /// The standard filter element (RM0440 §44.3.13): `SFT[31:30]` = 01 (dual ID; a single
    /// identifier is both IDs), `SFEC[29:27]` = 001 (store in Rx FIFO 0), `SFID1[26:16]`,
    /// `SFID2[10:0]`.
    pub const fn element(&self) -> u32 {
        let (a, b) = match *self {
            Self::Single(id) => (id, id),
            Self::Dual(a, b) => (a, b),
        };
        (0b01 << 30) | (0b001 << 27) | (((a & 0x7FF) as u32) << 16) | ((b & 0x7FF) as u32)
    }
}

/// The filter of `source`'s frames: its value identifier and, for an agent with a heartbeat
/// identifier, that one too.
pub fn filter_of<const K: usize>(node: &NodeConfig<K>, source: Source) -> Option<Accept> {
    let value = node.ids.value_id(source)?;
    let heartbeat = match source {
        Source::Agent(a) => node.ids.heartbeat_id(a),
        Source::Leader => None,
    };
    Some(match heartbeat {
        Some(hb) => Accept::Dual(value, hb),
        None => Accept::Single(value),
    })
}

/// The node takes the leader's frames: pinned, or the leader supervised.
pub fn uses_leader<const K: usize>(node: &NodeConfig<K>, pinned: bool) -> bool {
    pinned || node.supervisor.leader_timeout_us.is_some()
}

/// The filters in slot order: the CANopen device's (NMT `0x000` and its SDO requests
/// `0x600 + id`, CiA 301), the leader's (when [`uses_leader`]), this agent's own
/// identifiers (another node sending them is a misconfigured peer the node counts), each of
/// the first `neighbour_count` neighbours', and with `bench` the agent's plant-bus sensor
/// frame; the remaining slots disabled (`None`: an all-zero element, `SFEC` = 000).
pub fn acceptance<const K: usize>(
    node: &NodeConfig<K>,
    neighbour_count: usize,
    pinned: bool,
    bench: bool,
) -> [Option<Accept>; SLOTS] {
    let leader = uses_leader(node, pinned).then_some(Source::Leader);
    let own = core::iter::once(Source::Agent(node.agent));
    let neighbours = node
        .neighbours
        .iter()
        .take(neighbour_count)
        .map(|&a| Source::Agent(a));
    let sensor = plant_bus::Kind::Sensor
        .id(node.agent)
        .filter(|_| bench)
        .map(|id| Accept::Single(id.as_raw()));
    let canopen = Accept::Dual(NMT_ID, sdo_rx_id(node.agent));
    let mut out = [None; SLOTS];
    let filters = core::iter::once(canopen).chain(
        leader
            .into_iter()
            .chain(own)
            .chain(neighbours)
            .filter_map(|s| filter_of(node, s))
            .chain(sensor),
    );
    for (slot, f) in out.iter_mut().zip(filters) {
        *slot = Some(f);
    }
    out
}

/// `FDCAN_RXGFC[5:0]` as the set-up writes it: non-matching standard and extended frames
/// rejected (`ANFS` = `ANFE` = 11), remote frames rejected (`RRFS` = `RRFE` = 1).
pub const RXGFC_REJECT_ALL: u32 = (0b11 << 4) | (0b11 << 2) | (1 << 1) | 1;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{self, NODE};

    #[test]
    fn one_megabit_with_the_sample_point_at_83_percent() {
        assert_eq!(BIT_TIMING.quanta(), 24);
        assert_eq!(BIT_TIMING.bit_rate(KERNEL_HZ), 1_000_000);
        assert_eq!(KERNEL_HZ % (24 * 1_000_000), 0, "exact, no rate error");
        assert_eq!(BIT_TIMING.sample_point_permille(), 833);
    }

    #[test]
    fn nbtp_holds_each_field_minus_one() {
        // NSJW 3 << 25, NBRP 0 << 16, NTSEG1 18 << 8, NTSEG2 3.
        assert_eq!(BIT_TIMING.nbtp(), 0x0600_1203);
        let t = BitTiming {
            prescaler: 512,
            seg1: 255,
            seg2: 128,
            sjw: 128,
        };
        assert_eq!(
            t.nbtp(),
            0xFFFF_FE7F,
            "every field but NTSEG1 at its maximum"
        );
    }

    #[test]
    fn the_shipped_node_accepts_nmt_its_sdo_the_leader_itself_and_its_two_neighbours() {
        let c = config::controller();
        let f = acceptance(&NODE, c.neighbour_count, c.pinned, false);
        assert_eq!(
            f,
            [
                Some(Accept::Dual(0x000, 0x604)),
                Some(Accept::Single(0x101)),
                Some(Accept::Dual(0x105, 0x784)),
                Some(Accept::Dual(0x102, 0x781)),
                Some(Accept::Dual(0x104, 0x783)),
                None,
                None,
                None,
            ]
        );
        // The words in message RAM (SFT 01, SFEC 001 → 0x48 in the top byte).
        assert_eq!(Accept::Single(0x101).element(), 0x4901_0101);
        assert_eq!(Accept::Dual(0x105, 0x784).element(), 0x4905_0784);
        assert_eq!(RXGFC_REJECT_ALL, 0x3F);
    }

    #[test]
    fn the_bench_adds_the_agents_sensor_frame_and_a_silent_leader_is_not_listened_to() {
        let c = config::controller();
        let f = acceptance(&NODE, c.neighbour_count, c.pinned, true);
        assert_eq!(f[5], Some(Accept::Single(0x204)));
        let mut unsupervised = NODE;
        unsupervised.supervisor.leader_timeout_us = None;
        assert!(!uses_leader(&unsupervised, false));
        assert!(uses_leader(&unsupervised, true), "pinned");
        let f = acceptance(&unsupervised, c.neighbour_count, false, true);
        assert_eq!(f[1], Some(Accept::Dual(0x105, 0x784)));
        assert_eq!(f[4], Some(Accept::Single(0x204)));
    }

    /// The largest node the slots hold: NMT and SDO, leader, itself, `K` = 4 neighbours and
    /// the sensor frame fill the 8 slots.
    #[test]
    fn a_full_neighbour_list_still_fits_the_slots() {
        let mut n = NODE;
        n.neighbours = [1, 2, 3, 5];
        let f = acceptance(&n, 4, true, true);
        assert_eq!(f.iter().flatten().count(), 8);
        assert_eq!(f[7], Some(Accept::Single(0x204)));
        const {
            assert!(
                4 + config::K <= SLOTS,
                "NMT and SDO, leader, own, K neighbours, sensor"
            )
        };
    }
}
