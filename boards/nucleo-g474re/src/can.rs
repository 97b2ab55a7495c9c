//! FDCAN1 as the node's `embedded_can::nb::Can`: classic frames at 1 Mbit/s, acceptance filters
//! for the frames the node uses (leader, neighbours' values and heartbeats) and for its own
//! identifiers (another node using them is a misconfigured peer the node counts).
//!
//! Bit timing: the FDCAN kernel clock is the 24 MHz HSE; prescaler 1, 24 time quanta per bit
//! (sync 1 + seg1 19 + seg2 4), sample point 83.3 %, SJW 4 → 1 Mbit/s.

use core::num::{NonZeroU16, NonZeroU8};

use agent_node::{wire::Source, CanFrame, NodeConfig};
use embedded_can::{ErrorKind, Frame as _, Id};
use fdcan::{
    config::{FrameTransmissionConfig, GlobalFilter, NominalBitTiming},
    filter::{Action, FilterType, StandardFilter, StandardFilterSlot},
    frame::{FrameFormat, TxFrameHeader},
    id::{ExtendedId, StandardId},
    interrupt::{Interrupt, InterruptLine},
    ConfigMode, FdCan, NormalOperationMode, ReceiveErrorOverflow, ReceiveOverrun,
};
use stm32g4xx_hal::{can::Can as HalCan, stm32::FDCAN1};

/// 1 Mbit/s from the 24 MHz kernel clock.
const BIT_TIMING: NominalBitTiming = NominalBitTiming {
    prescaler: NonZeroU16::MIN,
    seg1: NonZeroU8::new(19).unwrap(),
    seg2: NonZeroU8::new(4).unwrap(),
    sync_jump_width: NonZeroU8::new(4).unwrap(),
};

/// The standard filter slots, in the order they are filled: the leader, this agent, then one
/// per neighbour (value and heartbeat identifiers in one dual-id filter each).
const SLOTS: [StandardFilterSlot; 8] = [
    StandardFilterSlot::_0,
    StandardFilterSlot::_1,
    StandardFilterSlot::_2,
    StandardFilterSlot::_3,
    StandardFilterSlot::_4,
    StandardFilterSlot::_5,
    StandardFilterSlot::_6,
    StandardFilterSlot::_7,
];

const _: () = assert!(
    SLOTS.len() >= 2 + crate::config::K,
    "a filter slot per source"
);

/// Why a frame was not sent or received.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CanError {
    /// A received frame whose identifier or length FDCAN reported out of range.
    Malformed,
    /// The node asked for a frame FDCAN cannot send as given (remote or empty data frame).
    Unsendable,
}

impl embedded_can::Error for CanError {
    fn kind(&self) -> ErrorKind {
        match self {
            Self::Malformed | Self::Unsendable => ErrorKind::Other,
        }
    }
}

type Configuring = FdCan<HalCan<FDCAN1>, ConfigMode>;
type Running = FdCan<HalCan<FDCAN1>, NormalOperationMode>;

/// FDCAN1: configured by [`configure`], on the bus only after [`Fdcan1::join_bus`].
pub struct Fdcan1 {
    mode: Mode,
    overruns: u32,
}

enum Mode {
    Configuring(Configuring),
    Running(Running),
    /// Only while [`Fdcan1::join_bus`] swaps the two.
    Switching,
}

/// The acceptance filter of `source`'s frames: its value identifier and, for an agent with a
/// heartbeat identifier, that one too.
fn filter_of<const K: usize>(node: &NodeConfig<K>, source: Source) -> Option<StandardFilter> {
    let value = StandardId::new(node.ids.value_id(source)?)?;
    let heartbeat = match source {
        Source::Agent(a) => node.ids.heartbeat_id(a).and_then(StandardId::new),
        Source::Leader => None,
    };
    Some(StandardFilter {
        filter: match heartbeat {
            Some(hb) => FilterType::DedicatedDual(value, hb),
            None => FilterType::DedicatedSingle(value),
        },
        action: Action::StoreInFifo0,
    })
}

/// Bit timing, classic frames only, the filters of [`SLOTS`] into FIFO 0 (the leader's only
/// when the node uses it: `pinned`, or a leader timeout supervised), every other frame
/// rejected, the FIFO 0 new-message interrupt on line 0 (every interrupt's line after
/// reset). The controller stays in its configuration mode (off the bus: nothing sent,
/// nothing acknowledged) until [`Fdcan1::join_bus`].
pub fn configure<const K: usize>(
    mut can: FdCan<HalCan<FDCAN1>, ConfigMode>,
    node: &NodeConfig<K>,
    neighbour_count: usize,
    pinned: bool,
) -> Fdcan1 {
    can.set_protocol_exception_handling(false);
    can.set_nominal_bit_timing(BIT_TIMING);
    can.set_frame_transmit(FrameTransmissionConfig::ClassicCanOnly);
    can.set_automatic_retransmit(true);
    can.set_global_filter(GlobalFilter::reject_all());
    let leader = pinned || node.supervisor.leader_timeout_us.is_some();
    let sources = leader
        .then_some(Source::Leader)
        .into_iter()
        .chain(core::iter::once(Source::Agent(node.agent)))
        .chain(
            node.neighbours
                .iter()
                .take(neighbour_count)
                .map(|&a| Source::Agent(a)),
        );
    let filters = sources.filter_map(|s| filter_of(node, s));
    for (slot, filter) in SLOTS.into_iter().zip(filters) {
        can.set_standard_filter(slot, filter);
    }
    can.enable_interrupt(Interrupt::RxFifo0NewMsg);
    can.enable_interrupt_line(InterruptLine::_0, true);
    Fdcan1 {
        mode: Mode::Configuring(can),
        overruns: 0,
    }
}

impl Fdcan1 {
    /// Normal operation: the controller takes part in the bus from now on.
    pub fn join_bus(&mut self) {
        self.mode = match core::mem::replace(&mut self.mode, Mode::Switching) {
            Mode::Configuring(c) => Mode::Running(c.into_normal()),
            other => other,
        };
    }

    fn running(&mut self) -> Option<&mut Running> {
        match &mut self.mode {
            Mode::Running(c) => Some(c),
            _ => None,
        }
    }

    /// Acknowledge the receive interrupt (the frames are taken by the node).
    pub fn clear_rx_interrupt(&mut self) {
        if let Some(c) = self.running() {
            c.clear_interrupt(Interrupt::RxFifo0NewMsg);
        }
    }

    /// Transmit and receive error counters (TEC, REC); zero off the bus.
    pub fn error_counters(&self) -> (u8, u8) {
        let Mode::Running(can) = &self.mode else {
            return (0, 0);
        };
        let c = can.error_counters();
        let rec = match c.receive_err {
            ReceiveErrorOverflow::Normal(n) | ReceiveErrorOverflow::Overflow(n) => n,
        };
        (c.transmit_err, rec)
    }

    /// The controller went bus-off (too many transmit errors) and stopped taking part.
    pub fn bus_off(&self) -> bool {
        match &self.mode {
            Mode::Running(c) => c.get_protocol_status().bus_off_status,
            _ => false,
        }
    }

    /// Receptions that found FIFO 0 had overflowed (frames lost before them).
    pub fn overruns(&self) -> u32 {
        self.overruns
    }
}

fn to_fdcan(id: Id) -> fdcan::id::Id {
    match id {
        Id::Standard(s) => StandardId::new(s.as_raw())
            .unwrap_or(StandardId::ZERO)
            .into(),
        Id::Extended(e) => ExtendedId::new(e.as_raw())
            .unwrap_or(ExtendedId::ZERO)
            .into(),
    }
}

fn from_fdcan(id: fdcan::id::Id) -> Option<Id> {
    Some(match id {
        fdcan::id::Id::Standard(s) => Id::Standard(embedded_can::StandardId::new(s.as_raw())?),
        fdcan::id::Id::Extended(e) => Id::Extended(embedded_can::ExtendedId::new(e.as_raw())?),
    })
}

impl embedded_can::nb::Can for Fdcan1 {
    type Frame = CanFrame;
    type Error = CanError;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, CanError> {
        let len = u8::try_from(frame.dlc()).unwrap_or(u8::MAX);
        if frame.is_remote_frame() || len == 0 || len > 8 {
            return Err(nb::Error::Other(CanError::Unsendable));
        }
        let header = TxFrameHeader {
            len,
            frame_format: FrameFormat::Standard,
            id: to_fdcan(frame.id()),
            bit_rate_switching: false,
            marker: None,
        };
        let mut pending = |_, h: TxFrameHeader, words: &[u32]| {
            let mut data = [0u8; 8];
            for (chunk, w) in data.chunks_exact_mut(4).zip(words) {
                chunk.copy_from_slice(&w.to_le_bytes());
            }
            let n = usize::from(h.len).min(8);
            from_fdcan(h.id).and_then(|id| CanFrame::new(id, &data[..n]))
        };
        let Some(can) = self.running() else {
            return Err(nb::Error::WouldBlock);
        };
        match can.transmit_preserve(header, frame.data(), &mut pending) {
            Ok(replaced) => Ok(replaced.flatten()),
            Err(nb::Error::WouldBlock) => Err(nb::Error::WouldBlock),
            Err(nb::Error::Other(never)) => match never {},
        }
    }

    fn receive(&mut self) -> nb::Result<CanFrame, CanError> {
        let mut buf = [0u8; 8];
        let Some(can) = self.running() else {
            return Err(nb::Error::WouldBlock);
        };
        let info = match can.receive0(&mut buf) {
            Ok(ReceiveOverrun::NoOverrun(i)) => i,
            Ok(ReceiveOverrun::Overrun(i)) => {
                self.overruns = self.overruns.saturating_add(1);
                i
            }
            Err(nb::Error::WouldBlock) => return Err(nb::Error::WouldBlock),
            Err(nb::Error::Other(never)) => match never {},
        };
        let n = usize::from(info.len).min(8);
        let frame = from_fdcan(info.id).and_then(|id| {
            if info.rtr {
                CanFrame::new_remote(id, n)
            } else {
                CanFrame::new(id, &buf[..n])
            }
        });
        frame.ok_or(nb::Error::Other(CanError::Malformed))
    }
}
