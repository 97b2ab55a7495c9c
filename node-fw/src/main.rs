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
//! Tasks (RTIC 2, `docs/FIRMWARE.md` §6): the UART receive interrupt (priority 3) moves each
//! byte into a bounded queue; CMSDK timer 0 (priority 2) releases the control task once per
//! sample period and counts a deadline overrun when the previous step is still running; the
//! control task (priority 1) takes the sample's lines from the queue, runs `Node::tick`, sends
//! the node's frame and the report, and feeds the watchdog only when the step ended before its
//! deadline (the next release). A node none of whose steps meets its deadline for the
//! configured late periods is reset by the watchdog.
//!
//! Measured per tick: the instructions of `Node::tick` (SysTick, 40-instruction resolution;
//! the UART traffic before and after and the wait for the host are not counted: the tick only
//! fills the mailbox and the actuator register), reported in the report record; the stack
//! high-water mark of the whole firmware (painted at start-up), reported on request in `STATS`.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

#[allow(unsafe_code)]
mod board;
#[allow(unsafe_code)]
mod pac;

use agent_node::{
    canopen::{Fault, Identity},
    link::{
        self, io, CanFrame, ConfigReject, Report, Slcan, MAX_CONFIG_WORDS, RECORD_MAX_LINE,
        SLCAN_MAX_LINE,
    },
    node::{Actuator, Clock, Node, Sensor},
};
use board::{SampleTimer, Watchdog};
use controller_core::StepFault;
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::NVIC;
use embedded_can::Frame as _;
use heapless::spsc::Consumer;
use panic_semihosting as _;

/// State order `n` and actuators `m` of the plants host-sim ships.
const N: usize = 2;
/// Actuators.
const M: usize = 2;
/// Neighbour capacity, the one of every node runtime.
const K: usize = agent_node::wire::MAX_NEIGHBOURS;
/// Received bus frames held between two ticks at most.
const RX_DEPTH: usize = 64;
/// Bytes the UART receive queue holds: a sample's input is at most 17 timestamped frames
/// (26 bytes each) and the tick record (17), so the host never sends more ahead of the node.
const RX_QUEUE: usize = 1024;
/// Bytes the receive interrupt dropped because the queue was full.
static RX_DROPPED: AtomicU32 = AtomicU32::new(0);
/// Releases that found the control task still running, since the start of its current step.
static LATE_RELEASES: AtomicU32 = AtomicU32::new(0);

/// Transmit mailboxes: the value frame and the heartbeat of one tick, and the CANopen
/// device's frames of a sample (boot-up and the first NMT heartbeat, SDO answer, EMCY), with
/// room to spare; sent in the order queued.
const TX_MAILBOXES: usize = 8;
/// `0x1017` producer heartbeat time of the CANopen device [ms] (of the network time).
const HEARTBEAT_MS: u16 = 100;
/// `0x1018` identity: product 2 (node-linux is 1), revision 1.
const IDENTITY: Identity = Identity {
    vendor: 0,
    product: 2,
    revision: 1,
    serial: 0,
};

/// The CAN controller: a receive FIFO filled from the SLCAN link, transmit mailboxes that
/// the main loop empties onto the link after the tick.
#[derive(Default)]
struct UartCan {
    rx: heapless::Deque<CanFrame, RX_DEPTH>,
    tx: heapless::Vec<CanFrame, TX_MAILBOXES>,
}

impl embedded_can::nb::Can for UartCan {
    type Frame = CanFrame;
    type Error = core::convert::Infallible;

    /// Queues `frame` after the others (none is replaced: the boot-up message and the first
    /// heartbeat share an identifier); busy when every mailbox is full.
    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
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

/// The control task's state: the receive queue's consumer end, the line being read, the node
/// once configured, the instruction counter and the network time of the last tick.
pub struct Control {
    rx: Consumer<'static, u8>,
    line: [u8; SLCAN_MAX_LINE],
    node: Option<BoardNode>,
    counter: Option<board::Counter>,
    painted: board::Painted,
    /// Timer counts per sample period; 0 until the sample timer runs.
    period_counts: u32,
    /// The watchdog's late periods (`io::WATCHDOG`); 0: no watchdog.
    watchdog_periods: u32,
    /// The watchdog runs.
    watchdog_on: bool,
    /// The watchdog's count while the control task is not running (see `control`).
    frozen: Option<board::Frozen>,
    /// Duration of each step in units of [`link::SLOW_PERIOD_UNIT`] (`io::SLOW`); 0: as fast
    /// as it computes.
    slow: u32,
    /// Time of the last tick, the origin of timestamps [µs], and the interval before it.
    sync_us: u64,
    dt_us: u32,
    /// The host asked the control task to stop at the next tick.
    hang: bool,
    /// This boot follows a watchdog reset: the device reports it by EMCY `0x6100`.
    watchdog_reset: bool,
}

impl Control {
    /// The next received byte. While the sample timer runs, waiting for the host stops the
    /// timer and freezes the watchdog (its count is kept, not fed), so the wait (host time,
    /// not the node's) takes no part of the period or of the watchdog's timeout: everything
    /// the node can observe stays a function of its instructions.
    fn byte(&mut self) -> u8 {
        if let Some(b) = self.rx.dequeue() {
            return b;
        }
        let timed = self.period_counts != 0;
        if timed {
            SampleTimer::pause();
        }
        let frozen = (timed && self.watchdog_on).then(Watchdog::freeze);
        let b = loop {
            if let Some(b) = self.rx.dequeue() {
                break b;
            }
            let rx = &self.rx;
            board::sleep_unless(|| rx.ready());
        };
        if let Some(f) = frozen {
            Watchdog::thaw(f);
        }
        if timed {
            SampleTimer::resume();
        }
        b
    }

    /// The watchdog's timeout: `late periods + ½` sample periods of the node's time; saturating.
    fn watchdog_timeout(&self) -> u32 {
        let p = u64::from(self.period_counts);
        let t = u64::from(self.watchdog_periods) * p + p / 2;
        u32::try_from(t).unwrap_or(u32::MAX)
    }

    /// The next command; malformed lines are answered with BEL (`\a`) and skipped, as is a
    /// receive-queue overflow.
    fn next(&mut self, send: &mut impl FnMut(&[u8])) -> Slcan {
        loop {
            let mut n = 0;
            let mut overflow = false;
            loop {
                match self.byte() {
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
            if RX_DROPPED.swap(0, Ordering::Relaxed) != 0 {
                send(b"\x07");
                continue;
            }
            if n == 0 && !overflow {
                continue;
            }
            match link::slcan_decode(&self.line[..n]) {
                Ok(cmd @ (Slcan::Frame(_) | Slcan::Timed(..) | Slcan::Tick(_))) if !overflow => {
                    return cmd
                }
                Ok(Slcan::Frame(_) | Slcan::Timed(..) | Slcan::Tick(_) | Slcan::Report(_))
                | Err(_) => send(b"\x07"),
                Ok(other) => {
                    send(b"\r");
                    return other;
                }
            }
        }
    }

    /// Waits for a complete configuration and builds the node; every rejection is reported
    /// and the node waits for the next attempt. Returns the sample period [µs].
    fn configure(&mut self, send: &mut impl FnMut(&[u8])) -> u32 {
        let mut words = [0u32; MAX_CONFIG_WORDS];
        let mut count = 0usize;
        loop {
            let (Slcan::Frame(f) | Slcan::Timed(f, _)) = self.next(send) else {
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
                Some(io::WATCHDOG) => match link::unpack_u32(f.data()) {
                    Some(periods) => {
                        self.watchdog_periods = periods;
                        continue;
                    }
                    None => {
                        count = 0;
                        ConfigReject::Unexpected
                    }
                },
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
                            // In place: the node, with its device, is several KiB.
                            Ok(node) => match self.node.insert(node).enable_canopen(
                                &node_cfg,
                                &ctrl_cfg,
                                IDENTITY,
                                false,
                                HEARTBEAT_MS,
                            ) {
                                Ok(()) => {
                                    send_io(send, io::READY, &[node_cfg.agent]);
                                    if let Some(node) = self.node.as_mut() {
                                        let reset = core::mem::take(&mut self.watchdog_reset);
                                        boot_device(send, node, reset);
                                    }
                                    // `Node::new` accepted `h` (finite, > 0).
                                    return (ctrl_cfg.h * 1e6) as u32;
                                }
                                Err(_) => {
                                    self.node = None;
                                    ConfigReject::Node
                                }
                            },
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
            send_io(send, io::REJECTED, &[reject as u8]);
        }
    }

    /// One released sample: the host's lines up to the tick record, then the tick, the
    /// node's frame and the report. Returns `false` if there is no node. Kept out of line so
    /// that the framework's share of a sample can be told apart in an execution trace.
    #[inline(never)]
    fn sample(&mut self, send: &mut impl FnMut(&[u8])) -> bool {
        loop {
            let (f, ts) = match self.next(send) {
                Slcan::Frame(f) => (f, None),
                Slcan::Timed(f, t) => (f, Some(t)),
                Slcan::Tick(t) => {
                    if self.hang {
                        // The stopped control task: only the watchdog ends this. The
                        // release keeps running (and counting overruns). A `nop`, not
                        // `spin_loop` (`yield`), which makes QEMU leave its execution loop
                        // each time round: 300 times slower on the host.
                        board::unmask_interrupts();
                        loop {
                            cortex_m::asm::nop();
                        }
                    }
                    self.dt_us = t.dt_us.unwrap_or(self.dt_us);
                    self.sync_us += u64::from(self.dt_us);
                    let Some(node) = self.node.as_mut() else {
                        return false;
                    };
                    node.clock_mut().0 = self.sync_us;
                    node.sensor_mut().0 = t.x;
                    let busy = (self.slow != 0).then(|| {
                        let counts = u64::from(self.period_counts) * u64::from(self.slow);
                        (
                            self.period_counts,
                            counts / u64::from(link::SLOW_PERIOD_UNIT),
                        )
                    });
                    tick(send, node, &mut self.counter, busy);
                    return true;
                }
                _ => continue,
            };
            let Some(node) = self.node.as_mut() else {
                return false;
            };
            if let Some(t) = ts {
                node.clock_mut().0 = self.sync_us + u64::from(t);
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
                (Some(io::HANG), _) => self.hang = true,
                (Some(io::SLOW), Some(units)) => self.slow = units,
                (Some(io::STATS_REQUEST), _) => {
                    let stack = board::stack_high_water(self.painted).to_le_bytes();
                    let bad = node.stats().malformed.total().to_le_bytes();
                    send_io(
                        send,
                        io::STATS,
                        &[
                            stack[0], stack[1], stack[2], stack[3], bad[0], bad[1], bad[2], bad[3],
                        ],
                    );
                }
                _ => send(b"\x07"),
            }
        }
    }
}

/// The CANopen device's boot (network time 0, before the first tick): the boot-up message
/// and the first heartbeat, pre-operational until the host's NMT start, and after a watchdog
/// reset (`watchdog_reset`) its EMCY `0x6100`; sent at once, after `READY`.
fn boot_device(send: &mut impl FnMut(&[u8]), node: &mut BoardNode, watchdog_reset: bool) {
    node.service();
    if watchdog_reset {
        node.report_fault(Fault::WatchdogReset, 1);
        node.service();
    }
    for f in &node.can_mut().tx {
        send_frame(send, f);
    }
    node.can_mut().tx.clear();
}

fn send_frame(send: &mut impl FnMut(&[u8]), frame: &CanFrame) {
    let mut buf = [0u8; SLCAN_MAX_LINE];
    let n = link::slcan_encode(frame, &mut buf);
    send(&buf[..n]);
}

fn send_io(send: &mut impl FnMut(&[u8]), id: u32, data: &[u8]) {
    if let Some(f) = CanFrame::io(id, data) {
        send_frame(send, &f);
    }
}

/// Busy (interrupts on, so that each release that finds the step running counts as it comes)
/// until more than `target` timer counts of the node's time have passed since this step's
/// release: the whole periods of the releases that found it running (`period` counts each)
/// and the part of the current one. `[[network.event]] kind = "slow"`: a step that computes
/// for `periods` sample periods.
fn busy_until(period: u32, target: u64) {
    board::unmask_interrupts();
    loop {
        let late = LATE_RELEASES.load(Ordering::Relaxed);
        let left = SampleTimer::value();
        // A release between the two reads restarted the period: read both again.
        if LATE_RELEASES.load(Ordering::Relaxed) != late {
            continue;
        }
        let elapsed = u64::from(late) * u64::from(period) + u64::from(period.saturating_sub(left));
        if elapsed > target {
            break;
        }
        // Not `spin_loop` (`yield`: QEMU leaves its execution loop at each one).
        cortex_m::asm::nop();
    }
    board::mask_interrupts();
}

/// Runs one `Node::tick`, stays busy for `busy` (`(period counts, step counts)`) when the step
/// is slowed, and sends the bus frame and the report (the step's outputs, at its end).
fn tick(
    send: &mut impl FnMut(&[u8]),
    node: &mut BoardNode,
    counter: &mut Option<board::Counter>,
    busy: Option<(u32, u64)>,
) {
    let start = counter.as_mut().map_or(0, board::Counter::start);
    let tick = node.tick();
    let end = counter.as_mut().map_or(0, board::Counter::stop);
    if let Some((period, target)) = busy {
        busy_until(period, target);
    }
    for f in &node.can_mut().tx {
        send_frame(send, f);
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
    send(&buf[..n]);
}

#[rtic::app(device = crate::pac, peripherals = false, dispatchers = [DUALTIMER])]
mod app {
    use super::*;
    use heapless::spsc::{Producer, Queue};

    #[shared]
    struct Shared {
        uart: board::Uart,
        timer: Option<SampleTimer>,
    }

    #[local]
    struct Local {
        uart_rx: board::UartRx,
        rx_in: Producer<'static, u8>,
        ctl: Control,
    }

    #[init(local = [queue: Queue<u8, RX_QUEUE> = Queue::new()])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let painted = board::paint_stack();
        let counter = Some(board::Counter::new(cx.core.SYST));
        let mut uart = board::Uart::init();
        send_io(
            &mut |b: &[u8]| uart.write_all(b),
            io::BOOT,
            &[link::PROTOCOL_VERSION],
        );
        let (rx_in, rx) = cx.local.queue.split();
        // The first run configures the node (a fresh task cannot be running yet).
        let _ = control::spawn();
        (
            Shared { uart, timer: None },
            Local {
                uart_rx: board::UartRx::new(),
                rx_in,
                ctl: Control {
                    rx,
                    line: [0; SLCAN_MAX_LINE],
                    node: None,
                    counter,
                    painted,
                    period_counts: 0,
                    watchdog_periods: link::DEFAULT_WATCHDOG_PERIODS,
                    watchdog_on: false,
                    frozen: None,
                    slow: 0,
                    sync_us: 0,
                    dt_us: 0,
                    hang: false,
                    watchdog_reset: board::take_watchdog_reset(),
                },
            },
        )
    }

    /// Sleeps between interrupts (RTIC's default idle spins, which under `-icount` turns every
    /// idle nanosecond into an emulated instruction).
    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// UART0 receive: every byte into the queue (counted and dropped when it is full).
    #[task(binds = UART0RX, priority = 3, local = [uart_rx, rx_in])]
    fn uart_rx(cx: uart_rx::Context) {
        while let Some(b) = cx.local.uart_rx.take() {
            if cx.local.rx_in.enqueue(b).is_err() {
                RX_DROPPED.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// Timer 0, once per sample period: releases the control task or, with the previous step
    /// still running, counts an overrun and tells the host. It never touches the watchdog.
    #[task(binds = TIMER0, priority = 2, shared = [uart, timer], local = [overruns: u32 = 0])]
    fn release(mut cx: release::Context) {
        if cx
            .shared
            .timer
            .lock(|t| t.as_ref().map(SampleTimer::restart))
            .is_none()
        {
            return;
        }
        if control::spawn().is_err() {
            LATE_RELEASES.fetch_add(1, Ordering::Relaxed);
            *cx.local.overruns += 1;
            let n = cx.local.overruns.to_le_bytes();
            cx.shared
                .uart
                .lock(|u| send_io(&mut |b: &[u8]| u.write_all(b), io::OVERRUN, &n));
        }
    }

    /// The control task: configuration on its first run, then one sample per release.
    #[task(priority = 1, local = [ctl], shared = [uart, timer])]
    async fn control(mut cx: control::Context) {
        let ctl = cx.local.ctl;
        let mut uart = cx.shared.uart;
        let mut send = |b: &[u8]| uart.lock(|u| u.write_all(b));
        // Interrupts wait while the task works; they run only where it waits for bytes
        // (`board::sleep_unless`), so where they nest on its stack is always the same.
        board::mask_interrupts();
        if ctl.node.is_none() {
            let period_us = ctl.configure(&mut send);
            let timer = SampleTimer::start(period_us);
            ctl.period_counts = timer.counts();
            if ctl.watchdog_periods != 0 {
                // As if a step had just met its deadline; counting from the first release.
                let _ = Watchdog::enable(ctl.watchdog_timeout());
                ctl.watchdog_on = true;
                ctl.frozen = Some(Watchdog::freeze());
            }
            cx.shared.timer.lock(|t| *t = Some(timer));
            board::unmask_interrupts();
            return;
        }
        // The watchdog counts while the task runs (less its waits for the host).
        if let Some(f) = ctl.frozen.take() {
            Watchdog::thaw(f);
        }
        // The releases that found the previous step running: the node counts them.
        let late_before = LATE_RELEASES.swap(0, Ordering::Relaxed);
        if let Some(node) = ctl.node.as_mut() {
            for _ in 0..late_before {
                node.record_overrun();
            }
        }
        ctl.sample(&mut send);
        // Ended before its deadline: no release found it running and none is waiting.
        let in_time =
            LATE_RELEASES.load(Ordering::Relaxed) == 0 && !NVIC::is_pending(pac::Interrupt::TIMER0);
        if ctl.watchdog_on {
            if in_time {
                Watchdog::feed(ctl.watchdog_timeout());
            }
            // Frozen until the next release: while the core sleeps, QEMU (`-icount`,
            // `sleep=on`) moves virtual time on by the host's real time, which a loaded host
            // stretches to many periods; that time is not the node's.
            ctl.frozen = Some(Watchdog::freeze());
        }
        board::unmask_interrupts();
    }
}
