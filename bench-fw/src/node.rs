//! The `node` variant: one `agent_node::Node::tick` per record of the trace — the CiA 301
//! device's work (received NMT/SDO/heartbeat frames, heartbeat producer, SDO timeout, EMCY),
//! sense, drain the received frames, freshness, supervision, `Controller::step`, actuate,
//! broadcast — instead of the step alone, so the table of cores can say what a node's whole
//! sample costs on a board.
//!
//! The node is agent 4 of Example 1 (hears agents 1 and 3, not pinned; stale timeout 2.5 ms,
//! as in `docs/NETWORK.md`; no supervision) and a CANopen device enabled as the NUCLEO-G474RE
//! board enables it (`Node::enable_canopen`: identity product 1 revision 1, heartbeat producer
//! 100 ms, not self-starting). As on the board, the device is started by an NMT master: before
//! the measured ticks the node boots (boot-up message, pre-operational) and an NMT "start
//! remote node" frame comes in through the CAN controller; every measured tick then runs
//! operational, and one tick in 100 (one period is 1 ms) also sends the heartbeat, so the
//! maximum includes such a tick and the median does not.
//!
//! Before each tick the two neighbours' value frames of the record are put in the CAN
//! controller's receive queue; the node's own frames (value, heartbeat) are accepted by the
//! transmit call. The node logs nothing in this build (agent-node without `defmt` or `log`).
//!
//! A tick changes the node (sequence counters, freshness, the controller, the device), and a
//! node is not `Copy`, so each tick is timed once: resolution one SysTick tick (40
//! instructions at 25 MHz), less the cost of an empty timing. The output lines are those of
//! the step benchmark with `reps=1`.

use crate::{
    measure::{elapsed, fail, paint_below, painted_depth},
    trace::{record, M, N},
};
use agent_node::{
    canopen::{CoFrame, Identity, NmtCommand, NmtState, NMT_ID},
    wire,
    wire::Source,
    Actuator, CanFrame, Clock, Node, NodeConfig, Sensor,
};
use controller_core::{ControllerConfig, Link};
use core::hint::black_box;
use cortex_m::peripheral::SYST;
use cortex_m_semihosting::hprintln;

/// Neighbour capacity of the node (agent 4 hears two).
const K: usize = 2;
/// The neighbours of agent 4 in Example 1.
const NEIGHBOURS: [u8; K] = [1, 3];
/// Sample period, µs (Example 1's `h`).
const PERIOD_US: u64 = 1_000;
/// Heartbeat producer time (`0x1017`), ms: the board's (`CANOPEN_HEARTBEAT_MS`).
const HEARTBEAT_MS: u16 = 100;

/// The CAN controller: a receive queue of the record's frames; transmit always accepts.
#[derive(Default)]
struct BenchCan {
    rx: [Option<CanFrame>; K],
    sent: u32,
}

impl embedded_can::nb::Can for BenchCan {
    type Frame = CanFrame;
    type Error = embedded_can::ErrorKind;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
        black_box(frame);
        self.sent = self.sent.wrapping_add(1);
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
        self.rx
            .iter_mut()
            .find_map(Option::take)
            .ok_or(nb::Error::WouldBlock)
    }
}

/// Time advancing one period per tick.
#[derive(Default)]
struct BenchClock {
    now_us: u64,
}

impl Clock for BenchClock {
    fn now_us(&mut self) -> u64 {
        self.now_us
    }
}

/// The record's own state.
#[derive(Default)]
struct TraceSensor {
    x: [f32; N],
}

impl Sensor<N> for TraceSensor {
    type Error = ();
    fn read(&mut self) -> Result<[f32; N], ()> {
        Ok(self.x)
    }
}

/// The written command, kept.
#[derive(Default)]
struct HeldCommand {
    q: [f32; M],
}

impl Actuator<M> for HeldCommand {
    type Error = ();
    fn write(&mut self, q: &[f32; M]) -> Result<(), ()> {
        self.q = *q;
        Ok(())
    }
}

type BenchNode = Node<BenchCan, BenchClock, TraceSensor, HeldCommand, N, M, K>;

/// The measured call: one tick, not inlined into the timing.
#[inline(never)]
fn tick_entry(node: &mut BenchNode) -> agent_node::Tick<N, M> {
    node.tick()
}

/// The node's construction (controller configuration included), a function of its own so the
/// xtask can size the code a firmware links for it.
/// The CANopen device is enabled here, as the board does right after constructing its node.
#[inline(never)]
fn new_entry(cfg: &ControllerConfig<N>) -> Result<BenchNode, agent_node::NodeError> {
    let node_cfg = NodeConfig::new(4, NEIGHBOURS, 2_500);
    let mut node = BenchNode::new(
        &node_cfg,
        cfg,
        BenchCan::default(),
        BenchClock::default(),
        TraceSensor::default(),
        HeldCommand::default(),
    )?;
    // The device's identity (`0x1018`): the board's.
    let identity = Identity {
        product: 1,
        revision: 1,
        ..Identity::default()
    };
    node.enable_canopen(&node_cfg, cfg, identity, false, HEARTBEAT_MS)?;
    Ok(node)
}

/// Boot the device (boot-up message, pre-operational) and start it with an NMT "start remote
/// node" frame received through the CAN controller, as an NMT master starts a board; not
/// timed. Fails the run if the device is not operational after it.
fn start(node: &mut BenchNode) {
    node.service();
    let id = node.canopen().map_or(0, |d| d.node_id());
    let start = CoFrame::new(NMT_ID, &[NmtCommand::Start.code(), id]).to_frame::<CanFrame>();
    if let Some(slot) = node.can_mut().rx.first_mut() {
        *slot = start;
    }
    node.service();
    if node.canopen().map(|d| d.nmt()) != Some(NmtState::Operational) {
        fail("the CANopen device did not enter Operational on the NMT start")
    }
}

/// One tick with the stack painted below the caller's; returns whether the controller held
/// its command, the stack bytes and the ticks.
#[inline(never)]
fn tick_with_stack(node: &mut BenchNode) -> (bool, u32, u32) {
    let sp = cortex_m::register::msp::read() as usize & !3;
    paint_below(sp);
    let t0 = SYST::get_current();
    let tick = tick_entry(node);
    let t1 = SYST::get_current();
    let faulted = black_box(tick).output.status.fault.is_some();
    (faulted, painted_depth(sp), elapsed(t0, t1))
}

/// Ticks of an empty timing (the SysTick reads).
#[inline(never)]
fn empty_timing() -> u32 {
    let t0 = SYST::get_current();
    black_box(());
    elapsed(t0, SYST::get_current())
}

/// Runs the node over `steps` records; prints the step lines and the `BENCH` line.
pub fn run(cfg: &ControllerConfig<N>, steps: usize, calib_ticks: u32, calib_insns: u32) {
    let Ok(mut node) = new_entry(black_box(cfg)) else {
        fail("the node rejected its configuration")
    };
    start(&mut node);
    let (mut stack_peak, mut faults, mut total) = (0u32, 0u32, 0u64);
    let mut overhead = u32::MAX;
    for k in 0..steps {
        let (x, neighbours, _leader) = record(k);
        let seq = (k as u8) % wire::SEQ_MODULUS;
        for ((slot, &agent), link) in node
            .can_mut()
            .rx
            .iter_mut()
            .zip(NEIGHBOURS.iter())
            .zip(neighbours)
        {
            let y = match link {
                Link::Fresh(y) => y,
                _ => f32::NAN,
            };
            *slot = wire::encode::<CanFrame>(Source::Agent(agent), y, seq).map(|(f, _)| f);
        }
        node.clock_mut().now_us = k as u64 * PERIOD_US;
        node.sensor_mut().x = x;
        overhead = overhead.min(empty_timing());
        let (faulted, stack, ticks) = tick_with_stack(&mut node);
        hprintln!("T {}", ticks);
        total += u64::from(ticks);
        stack_peak = stack_peak.max(stack);
        faults += u32::from(faulted);
    }
    hprintln!(
        "BENCH steps={} reps=1 stack={} state={} mutable_state={} faults={} overhead_ticks={} coarse_ticks={} calib_ticks={} calib_insns={} accepted={} sent={}",
        steps,
        stack_peak,
        core::mem::size_of::<BenchNode>(),
        core::mem::size_of::<BenchNode>(),
        faults,
        overhead,
        total,
        calib_ticks,
        calib_insns,
        node.stats().accepted,
        node.can().sent
    );
}
