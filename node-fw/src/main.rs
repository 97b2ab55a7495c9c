//! Processor-in-the-loop node firmware: one follower agent on an emulated Cortex-M4F (QEMU
//! `mps2-an386`, `-icount shift=0`), started by `host-sim` for `[network] kind = "pil"`.
//!
//! `agent_node::Node`, unchanged, runs over this board: its CAN controller is an SLCAN link on
//! UART0 ([`UartCan`]), its clock is the network time the host sends ([`NetClock`]), its
//! sensor and actuator are process-I/O frames ([`PlantSensor`], [`HeldCommand`]). The link
//! protocol (identifiers, one sample's exchange, start-up configuration) is
//! `agent_node::link`; `docs/NETWORK.md` §9 describes it. One binary serves every agent: the agent
//! number, its neighbours and the controller configuration arrive at start-up.
//!
//! Measured per tick: the instructions of `Node::tick` (SysTick, 40-instruction resolution;
//! the UART traffic before and after and the wait for the host are not counted: the tick only
//! fills the mailbox and the actuator register), reported in the report record; the stack high-water mark of the whole
//! firmware (painted at start-up), reported on request in `STATS`.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

#[allow(unsafe_code)]
mod board;

use agent_node::{
    link::{
        self, io, CanFrame, ConfigReject, Report, Slcan, MAX_CONFIG_WORDS, RECORD_MAX_LINE,
        SLCAN_MAX_LINE,
    },
    node::{Actuator, Clock, Node, Sensor},
};
use board::Uart;
use controller_core::StepFault;
use cortex_m_rt::entry;
use embedded_can::Frame as _;
use panic_semihosting as _;

/// State order `n` and actuators `m` of the plants host-sim ships.
const N: usize = 2;
/// Actuators.
const M: usize = 2;
/// Neighbour capacity, as host-sim's (`graph::MAX_NEIGHBOURS`).
const K: usize = 16;
/// Received bus frames held between two ticks at most.
const RX_DEPTH: usize = 64;

/// Transmit mailboxes: the value frame and the heartbeat of one tick.
const TX_MAILBOXES: usize = 2;

/// The CAN controller: a receive FIFO filled from the SLCAN link, two transmit mailboxes that
/// the main loop empties onto the link after the tick.
#[derive(Default)]
struct UartCan {
    rx: heapless::Deque<CanFrame, RX_DEPTH>,
    tx: heapless::Vec<CanFrame, TX_MAILBOXES>,
}

impl embedded_can::nb::Can for UartCan {
    type Frame = CanFrame;
    type Error = core::convert::Infallible;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
        if let Some(old) = self.tx.iter_mut().find(|f| f.raw_id() == frame.raw_id()) {
            return Ok(Some(core::mem::replace(old, *frame)));
        }
        self.tx.push(*frame).map_err(|_| nb::Error::WouldBlock)?;
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
        self.rx.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

/// Network time [µs], set by the host's `CLOCK` frames, timestamps and ticks.
#[derive(Default)]
struct NetClock(u64);

impl Clock for NetClock {
    fn now_us(&mut self) -> u64 {
        self.0
    }
}

/// The state of the latest tick record.
#[derive(Default)]
struct PlantSensor([f32; N]);

impl Sensor<N> for PlantSensor {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<[f32; N], Self::Error> {
        Ok(self.0)
    }
}

/// The actuator register: the commands of the last tick, sent in the report after it.
#[derive(Default)]
struct HeldCommand([f32; M]);

impl Actuator<M> for HeldCommand {
    type Error = core::convert::Infallible;
    fn write(&mut self, q: &[f32; M]) -> Result<(), Self::Error> {
        self.0 = *q;
        Ok(())
    }
}

type BoardNode = Node<UartCan, NetClock, PlantSensor, HeldCommand, N, M, K>;

/// Reads SLCAN lines from the UART.
struct Link {
    uart: Uart,
    line: [u8; SLCAN_MAX_LINE],
}

impl Link {
    /// The next command; malformed lines are answered with BEL (`\a`) and skipped.
    fn next(&mut self) -> Slcan {
        loop {
            let mut n = 0;
            let mut overflow = false;
            loop {
                match self.uart.read_byte() {
                    b'\r' => break,
                    b'\n' => {}
                    b => match self.line.get_mut(n) {
                        Some(slot) => {
                            *slot = b;
                            n += 1;
                        }
                        None => overflow = true,
                    },
                }
            }
            if n == 0 && !overflow {
                continue;
            }
            match link::slcan_decode(&self.line[..n]) {
                Ok(cmd @ (Slcan::Frame(_) | Slcan::Timed(..) | Slcan::Tick(_))) if !overflow => {
                    return cmd
                }
                Ok(Slcan::Frame(_) | Slcan::Timed(..) | Slcan::Tick(_) | Slcan::Report(_))
                | Err(_) => self.uart.write_all(b"\x07"),
                Ok(other) => {
                    self.uart.write_all(b"\r");
                    return other;
                }
            }
        }
    }

    fn send(&self, frame: &CanFrame) {
        let mut buf = [0u8; SLCAN_MAX_LINE];
        let n = link::slcan_encode(frame, &mut buf);
        self.uart.write_all(&buf[..n]);
    }

    fn send_io(&self, id: u32, data: &[u8]) {
        if let Some(f) = CanFrame::io(id, data) {
            self.send(&f);
        }
    }
}

/// Waits for a complete configuration and builds the node; every rejection is reported and
/// the node waits for the next attempt.
fn configure(link: &mut Link) -> BoardNode {
    let mut words = [0u32; MAX_CONFIG_WORDS];
    let mut count = 0usize;
    loop {
        let (Slcan::Frame(f) | Slcan::Timed(f, _)) = link.next() else {
            continue;
        };
        let reject = match f.io_id() {
            Some(io::CONFIG) if f.data().len() % 4 == 0 => {
                for w in f.data().chunks_exact(4) {
                    if let Some(slot) = words.get_mut(count) {
                        *slot = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
                    }
                    count += 1;
                }
                continue;
            }
            Some(io::CONFIG_END) => {
                let sent = match *f.data() {
                    [lo, hi] => usize::from(u16::from_le_bytes([lo, hi])),
                    _ => usize::MAX,
                };
                let result = if sent != count || count > MAX_CONFIG_WORDS {
                    Err(ConfigReject::WordCount)
                } else {
                    link::decode_config::<N, K>(&words[..count])
                };
                count = 0;
                match result {
                    Ok((node_cfg, ctrl_cfg)) => match Node::new(
                        &node_cfg,
                        &ctrl_cfg,
                        UartCan::default(),
                        NetClock::default(),
                        PlantSensor::default(),
                        HeldCommand::default(),
                    ) {
                        Ok(node) => {
                            link.send_io(io::READY, &[node_cfg.agent]);
                            return node;
                        }
                        Err(_) => ConfigReject::Node,
                    },
                    Err(e) => e,
                }
            }
            _ => {
                count = 0;
                ConfigReject::Unexpected
            }
        };
        link.send_io(io::REJECTED, &[reject as u8]);
    }
}

/// Runs one sample and sends the bus frame and the report.
fn sample(link: &Link, node: &mut BoardNode, counter: &mut Option<board::Counter>) {
    let start = counter.as_mut().map_or(0, board::Counter::start);
    let tick = node.tick();
    let end = counter.as_mut().map_or(0, board::Counter::stop);
    for f in &node.can_mut().tx {
        link.send(f);
    }
    node.can_mut().tx.clear();
    let o = &tick.output;
    let l = &o.status.links;
    let report = Report {
        q: node.actuator().0,
        u: o.u,
        e: o.e,
        mu: o.estimates.mu,
        xi: o.estimates.xi,
        lambda: o.estimates.lambda,
        fault: match o.status.fault {
            None => 0,
            Some(StepFault::InvalidState) => 1,
            Some(StepFault::NonFiniteResult) => 2,
        },
        stale: l.stale_neighbours,
        missing: l.missing_neighbours,
        leader: u8::from(l.leader_stale) | (u8::from(l.leader_missing) << 1),
        state: tick.state.code(),
        instructions: board::instructions(start, end),
        resolution: board::INSN_PER_TICK,
    };
    let mut buf = [0u8; RECORD_MAX_LINE];
    let n = link::report_encode(&report, &mut buf);
    link.uart.write_all(&buf[..n]);
}

#[entry]
fn main() -> ! {
    let painted = board::paint_stack();
    let mut counter = cortex_m::Peripherals::take().map(|p| board::Counter::new(p.SYST));
    let mut link = Link {
        uart: Uart::init(),
        line: [0; SLCAN_MAX_LINE],
    };
    let mut node = configure(&mut link);
    // Time of the last tick, the origin of timestamps [µs], and the interval before it.
    let mut sync_us = 0u64;
    let mut dt_us = 0u32;
    loop {
        let (f, ts) = match link.next() {
            Slcan::Frame(f) => (f, None),
            Slcan::Timed(f, t) => (f, Some(t)),
            Slcan::Tick(t) => {
                dt_us = t.dt_us.unwrap_or(dt_us);
                sync_us += u64::from(dt_us);
                node.clock_mut().0 = sync_us;
                node.sensor_mut().0 = t.x;
                sample(&link, &mut node, &mut counter);
                continue;
            }
            _ => continue,
        };
        if let Some(t) = ts {
            node.clock_mut().0 = sync_us + u64::from(t);
        }
        match (f.io_id(), link::unpack_u32(f.data())) {
            (None, _) => {
                // A bus frame: into the receive FIFO, taken now (the receive interrupt).
                if node.can_mut().rx.push_back(f).is_ok() {
                    node.poll_rx();
                }
            }
            (Some(io::CLOCK), Some(t)) => {
                let c = &mut node.clock_mut().0;
                *c = link::extend_clock(*c, t);
            }
            (Some(io::STATS_REQUEST), _) => {
                let stack = board::stack_high_water(painted).to_le_bytes();
                let bad = node.stats().malformed.total().to_le_bytes();
                link.send_io(
                    io::STATS,
                    &[
                        stack[0], stack[1], stack[2], stack[3], bad[0], bad[1], bad[2], bad[3],
                    ],
                );
            }
            _ => link.uart.write_all(b"\x07"),
        }
    }
}
