//! FDCAN1 as the node's `embedded_can::nb::Can`: classic frames at 1 Mbit/s, acceptance filters
//! for the frames the node uses (leader, neighbours' values and heartbeats), for its own
//! identifiers (another node using them is a misconfigured peer the node counts) and, on the
//! bench, for its plant-bus sensor frame. The values written are those of
//! [`nucleo_g474re::can_setup`] (bit timing: prescaler 1, 24 quanta, sample point 83.3 %,
//! SJW 4 from the 24 MHz HSE).
//!
//! Besides the node's frames, [`Fdcan1`] notes what the board itself needs as frames pass:
//! that a valid leader value arrived (for the output gate's freshness) and, on the bench, the
//! latest sensor frame (kept here, never handed to the node). [`Fdcan1::restart`] clears
//! `INIT` after a bus-off ([`nucleo_g474re::bus_off`]).

use core::num::{NonZeroU16, NonZeroU8};

use agent_node::{
    plant_bus,
    wire::{self, Decoded, IdPlan, Source},
    CanFrame, NodeConfig,
};
use embedded_can::{ErrorKind, Frame as _, Id};
use fdcan::{
    config::{FrameTransmissionConfig, GlobalFilter, NominalBitTiming},
    filter::{Action, FilterType, StandardFilter, StandardFilterSlot},
    frame::{FrameFormat, TxFrameHeader},
    id::{ExtendedId, StandardId},
    interrupt::{Interrupt, InterruptLine},
    ConfigMode, FdCan, NormalOperationMode, ReceiveErrorOverflow, ReceiveOverrun,
};
use nucleo_g474re::can_setup::{self, Accept, BIT_TIMING};
use stm32g4xx_hal::{can::Can as HalCan, stm32::FDCAN1};

/// A bit-timing field as the `fdcan` crate takes it (every field is at least 1: a compile-time
/// check of `can_setup`).
const fn non_zero(v: u8) -> NonZeroU8 {
    match NonZeroU8::new(v) {
        Some(n) => n,
        None => NonZeroU8::MIN,
    }
}

/// [`BIT_TIMING`] as the `fdcan` crate takes it.
const NOMINAL: NominalBitTiming = NominalBitTiming {
    prescaler: match NonZeroU16::new(BIT_TIMING.prescaler) {
        Some(p) => p,
        None => NonZeroU16::MIN,
    },
    seg1: non_zero(BIT_TIMING.seg1),
    seg2: non_zero(BIT_TIMING.seg2),
    sync_jump_width: non_zero(BIT_TIMING.sjw),
};

/// The standard filter slots, in the order [`can_setup::acceptance`] fills them.
const SLOTS: [StandardFilterSlot; can_setup::SLOTS] = [
    StandardFilterSlot::_0,
    StandardFilterSlot::_1,
    StandardFilterSlot::_2,
    StandardFilterSlot::_3,
    StandardFilterSlot::_4,
    StandardFilterSlot::_5,
    StandardFilterSlot::_6,
    StandardFilterSlot::_7,
];

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
    ids: IdPlan,
    agent: u8,
    /// A valid leader value arrived since [`Fdcan1::take_leader_heard`].
    leader_heard: bool,
    /// The latest sensor frame since [`Fdcan1::take_sensor`] (bench).
    sensor: Option<[f32; 2]>,
}

enum Mode {
    Configuring(Configuring),
    Running(Running),
    /// Only while [`Fdcan1::join_bus`] or [`Fdcan1::restart`] swaps the two.
    Switching,
}

/// The `fdcan` filter of one acceptance entry, into FIFO 0.
fn to_filter(a: Accept) -> Option<StandardFilter> {
    let filter = match a {
        Accept::Single(id) => FilterType::DedicatedSingle(StandardId::new(id)?),
        Accept::Dual(a, b) => FilterType::DedicatedDual(StandardId::new(a)?, StandardId::new(b)?),
    };
    Some(StandardFilter {
        filter,
        action: Action::StoreInFifo0,
    })
}

/// Bit timing, classic frames only, every frame rejected until [`Fdcan1::listen`] sets the
/// filters of [`can_setup::acceptance`] into FIFO 0, the FIFO 0 new-message interrupt on line 0
/// (every interrupt's line after reset). The controller stays in its configuration mode (off
/// the bus: nothing sent, nothing acknowledged) until [`Fdcan1::join_bus`].
pub fn configure(mut can: FdCan<HalCan<FDCAN1>, ConfigMode>) -> Fdcan1 {
    can.set_protocol_exception_handling(false);
    can.set_nominal_bit_timing(NOMINAL);
    can.set_frame_transmit(FrameTransmissionConfig::ClassicCanOnly);
    can.set_automatic_retransmit(true);
    can.set_global_filter(GlobalFilter::reject_all());
    can.enable_interrupt(Interrupt::RxFifo0NewMsg);
    can.enable_interrupt_line(InterruptLine::_0, true);
    Fdcan1 {
        mode: Mode::Configuring(can),
        overruns: 0,
        ids: IdPlan::DEFAULT,
        agent: 0,
        leader_heard: false,
        sensor: None,
    }
}

impl Fdcan1 {
    /// The acceptance filters of [`can_setup::acceptance`] for `node`, once, while still in the
    /// configuration mode (before [`Self::join_bus`]); nothing once on the bus. The firmware sets them for the stored node-ID, graph row and
    /// plan once the CANopen device has loaded them.
    pub fn listen<const K: usize>(
        &mut self,
        node: &NodeConfig<K>,
        neighbour_count: usize,
        pinned: bool,
    ) {
        let Mode::Configuring(can) = &mut self.mode else {
            return;
        };
        let filters = can_setup::acceptance(node, neighbour_count, pinned, cfg!(feature = "bench"));
        for (slot, filter) in SLOTS.into_iter().zip(filters) {
            if let Some(f) = filter.and_then(to_filter) {
                can.set_standard_filter(slot, f);
            }
        }
        self.ids = node.ids;
        self.agent = node.agent;
    }

    /// Normal operation: the controller takes part in the bus from now on.
    pub fn join_bus(&mut self) {
        self.mode = match core::mem::replace(&mut self.mode, Mode::Switching) {
            Mode::Configuring(c) => Mode::Running(c.into_normal()),
            other => other,
        };
    }

    /// After bus-off: clear `INIT` (through the configuration mode, which keeps the bit
    /// timing and the filters), so the FDCAN counts 128 × 11 recessive bits and returns to the
    /// bus with its error counters at zero.
    pub fn restart(&mut self) {
        self.mode = match core::mem::replace(&mut self.mode, Mode::Switching) {
            Mode::Running(c) => Mode::Running(c.into_config_mode().into_normal()),
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

    /// `FDCAN_PSR.BO`: the controller is bus-off (too many transmit errors), or still counting
    /// the recessive bits of its recovery.
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

    /// A valid leader value was received since the last call.
    pub fn take_leader_heard(&mut self) -> bool {
        core::mem::take(&mut self.leader_heard)
    }

    /// The latest sensor frame received since the last call (bench).
    #[cfg_attr(not(feature = "bench"), allow(dead_code))]
    pub fn take_sensor(&mut self) -> Option<[f32; 2]> {
        self.sensor.take()
    }

    /// Send a plant-bus frame (bench: command frames); `false` if not queued.
    #[cfg_attr(not(feature = "bench"), allow(dead_code))]
    pub fn send(&mut self, frame: Option<CanFrame>) -> bool {
        frame.is_some_and(|f| embedded_can::nb::Can::transmit(self, &f).is_ok())
    }

    /// Note what the board needs from a received frame; `true` if it is the board's own
    /// (a sensor frame) and not the node's.
    fn tap(&mut self, frame: &CanFrame) -> bool {
        if let Ok(Decoded::Value(m)) = wire::decode_in(&self.ids, frame) {
            if m.source == Source::Leader && m.y.is_some() {
                self.leader_heard = true;
            }
            return false;
        }
        match plant_bus::decode(frame) {
            Some(plant_bus::PlantFrame::Sensor(a, x)) if a == self.agent => {
                self.sensor = Some(x);
                true
            }
            _ => false,
        }
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

    /// The next frame for the node; sensor frames are kept for the board on the way.
    fn receive(&mut self) -> nb::Result<CanFrame, CanError> {
        loop {
            let frame = self.receive_one()?;
            if !self.tap(&frame) {
                return Ok(frame);
            }
        }
    }
}

impl Fdcan1 {
    /// One frame from FIFO 0, whatever it is.
    fn receive_one(&mut self) -> nb::Result<CanFrame, CanError> {
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
