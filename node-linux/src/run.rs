//! The node process: `agent_node::Node` over two SocketCAN sockets on one interface, paced by
//! its own timer.
//!
//! * The *bus* socket, owned by the `Node`, receives every frame but the plant-bus ones
//!   (`0x200..=0x3FF`, kernel filters) and sends this agent's value frame, its status PDO and
//!   its CANopen frames (heartbeat `0x700 + id`, EMCY, SDO).
//! * The *plant* socket receives only this agent's sensor frame and sends its command frame
//!   (`agent_node::plant_bus`); the `Sensor` and `Actuator` of the node share it.
//!
//! What the node is doing is said by CANopen alone (docs/NETWORK.md §11): its NMT state in the
//! heartbeat, the host's silence by EMCY `0x8250` ([`Fault::HostLost`]). The node waits for the
//! first sensor frame, then samples every `h` on the monotonic clock, at absolute deadlines half
//! a period after that frame's arrival (so the host's sample is on the bus before the node's
//! and the command is back before the host's next one). A deadline missed by more than `h/2`
//! counts as a late tick; when the process falls a whole period behind, the missed samples are
//! skipped, not run in a burst. It stops on an NMT stop with `[node.canopen] exit_on_stop` (the
//! end of a bench run, [`stop_commanded`]), on SIGINT/SIGTERM, when no sensor frame came for
//! `host_timeout` while running (the host is gone), and when none came within `start_timeout`
//! of starting (the run never began).

use std::{
    cell::RefCell,
    io,
    rc::Rc,
    sync::{
        atomic::{AtomicBool, Ordering},
        Arc,
    },
    time::{Duration, Instant},
};

use agent_node::{
    canopen::{heartbeat_id, CoFrame, NmtState},
    canopen::{Fault, Identity},
    node::CanOpenRequest,
    plant_bus::{self, Kind, PlantFrame},
    Actuator, Clock, Node, Sensor,
};
use embedded_can::Frame as _;
use socketcan::{
    errors::{ControllerProblems, CAN_ERR_BUSOFF, CAN_ERR_CRTL, CAN_ERR_RESTARTED},
    CanAnyFrame, CanError, CanFdFrame, CanFdSocket, CanFilter, CanSocket, Socket, SocketOptions,
};

use crate::config::{CanOpenSection, NodeFile, MAX_NEIGHBOURS, N};

/// The node as `run` builds it.
type LinuxNode = Node<BusSocket, MonoClock, BusSensor, BusActuator, N, N, MAX_NEIGHBOURS>;

/// Most bytes of a stored object dictionary (`0x1010`).
const STORE_CAPACITY: usize = 4096;

/// Why the node stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// An NMT stop with `exit_on_stop`: the normal end of a bench run ([`stop_commanded`]).
    Commanded,
    /// SIGINT or SIGTERM.
    Signal,
    /// No sensor frame within `host_timeout` while running.
    HostLost,
    /// No sensor frame within `start_timeout` of starting: the run never began.
    NeverStarted,
}

impl Stop {
    /// The process exit status (docs/NETWORK.md §11): 0 for a commanded or signalled stop, 3
    /// when the host went silent or never came.
    pub fn exit_status(self) -> u8 {
        match self {
            Self::Commanded | Self::Signal => 0,
            Self::HostLost | Self::NeverStarted => 3,
        }
    }
}

/// Whether the node ends its run on the master's command: the one place that decides it. The
/// command is CiA 301's NMT stop (`0x000`, command specifier `0x02`, to this node-ID or to all),
/// which leaves the device `nmt` in stopped; the process ends on it only with
/// `[node.canopen] exit_on_stop` (host-sim writes it for its bench runs), else a stopped
/// node stays, answering NMT and sending its heartbeat, as CiA 301 has it.
pub fn stop_commanded(nmt: Option<NmtState>, exit_on_stop: bool) -> bool {
    exit_on_stop && nmt == Some(NmtState::Stopped)
}

/// Opens a CAN socket on `interface` with the error a user can act on.
pub fn open(interface: &str) -> io::Result<CanSocket> {
    CanSocket::open(interface).map_err(|e| explain_open_error(interface, e))
}

/// Opens a socket on `interface` that reads and writes classical and CAN FD frames.
pub fn open_fd(interface: &str) -> io::Result<CanFdSocket> {
    CanFdSocket::open(interface).map_err(|e| explain_open_error(interface, e))
}

/// `frame` as it goes on the wire: with `fd` a CAN FD frame with bit-rate switching (same
/// identifier and data), else a classical frame; `None` for a frame CAN FD cannot carry (a
/// remote frame) or data beyond 64 bytes.
pub fn on_wire(frame: &impl embedded_can::Frame, fd: bool) -> Option<CanAnyFrame> {
    if fd {
        if frame.is_remote_frame() {
            return None;
        }
        let mut f = CanFdFrame::new(frame.id(), frame.data())?;
        f.set_brs(true);
        Some(CanAnyFrame::Fd(f))
    } else if frame.is_remote_frame() {
        CanAnyFrame::new_remote(frame.id(), frame.dlc())
    } else {
        CanAnyFrame::new(frame.id(), frame.data())
    }
}

/// The error classes the bus socket receives as error frames: bus-off, the controller's
/// restart after it, and the controller's problems (its receive overflow among them).
pub const ERROR_CLASSES: u32 = CAN_ERR_BUSOFF | CAN_ERR_RESTARTED | CAN_ERR_CRTL;

/// Receive-overflow EMCYs go out at most this often (each carries the running count).
pub const RX_OVERFLOW_EMCY_INHIBIT: Duration = Duration::from_secs(1);

/// The EMCYs an error frame of the bus socket raises (docs/NETWORK.md §12): the controller's
/// restart after bus-off (`CAN_ERR_RESTARTED`) is [`Fault::BusOff`] `0x8140` ("recovered from
/// bus-off": while bus-off nothing can be sent), a receive overflow of the controller
/// (`CAN_ERR_CRTL` with `CAN_ERR_CRTL_RX_OVERFLOW`) is [`Fault::RxOverflow`] `0x8110`; bus-off
/// itself, warnings and the rest raise none.
pub fn faults_of(e: &CanError) -> Vec<Fault> {
    let mut faults = Vec::new();
    if e.is_restarted() {
        faults.push(Fault::BusOff);
    }
    if e.controller()
        .is_some_and(|p| p.contains(ControllerProblems::RX_OVERFLOW))
    {
        faults.push(Fault::RxOverflow);
    }
    faults
}

/// The node's bus socket: classical frames, or every frame sent as CAN FD with bit-rate
/// switching (`fd`); received frames of either kind go to the `Node` as they are, error frames
/// as receive errors, and the faults they raise wait in the socket until the run loop takes them.
pub struct BusSocket {
    socket: CanFdSocket,
    fd: bool,
    faults: CanFaults,
}

/// Faults raised by the bus socket's error frames, not yet reported, and their counts.
#[derive(Debug, Default)]
pub struct CanFaults {
    raised: Vec<Fault>,
    /// Bus-off recoveries and receive overflows since start (the EMCYs' counts).
    bus_offs: u32,
    rx_overflows: u32,
    last_overflow_emcy: Option<Instant>,
}

impl CanFaults {
    /// An error frame came: keep the faults it raises ([`faults_of`]).
    pub fn raise(&mut self, e: &CanError) {
        self.raised.extend(faults_of(e));
    }

    /// The faults raised since the last call with their counts since start; receive
    /// overflows at most once per [`RX_OVERFLOW_EMCY_INHIBIT`] (the next one carries the
    /// overflows in between in its count).
    pub fn take(&mut self, now: Instant) -> Vec<(Fault, u32)> {
        let mut out = Vec::new();
        for f in std::mem::take(&mut self.raised) {
            match f {
                Fault::RxOverflow => {
                    self.rx_overflows = self.rx_overflows.saturating_add(1);
                    let due = self.last_overflow_emcy.is_none_or(|t| {
                        now.saturating_duration_since(t) >= RX_OVERFLOW_EMCY_INHIBIT
                    });
                    if due {
                        self.last_overflow_emcy = Some(now);
                        out.push((f, self.rx_overflows));
                    }
                }
                Fault::BusOff => {
                    self.bus_offs = self.bus_offs.saturating_add(1);
                    out.push((f, self.bus_offs));
                }
                _ => out.push((f, 0)),
            }
        }
        out
    }
}

impl embedded_can::nb::Can for BusSocket {
    type Frame = CanAnyFrame;
    type Error = socketcan::Error;

    fn receive(&mut self) -> nb::Result<CanAnyFrame, socketcan::Error> {
        let r = self.socket.receive();
        if let Err(nb::Error::Other(socketcan::Error::Can(e))) = &r {
            if e.is_bus_off() {
                log::warn!("CAN controller bus-off");
            }
            self.faults.raise(e);
        }
        r
    }

    fn transmit(
        &mut self,
        frame: &CanAnyFrame,
    ) -> nb::Result<Option<CanAnyFrame>, socketcan::Error> {
        match on_wire(frame, self.fd) {
            Some(f) => self.socket.transmit(&f),
            None => Err(nb::Error::Other(socketcan::Error::from(io::Error::new(
                io::ErrorKind::InvalidInput,
                "a remote frame cannot go out as CAN FD",
            )))),
        }
    }
}

/// Whether this kernel opens CAN sockets at all (`AF_CAN`, the `can` and `can-raw` modules).
pub fn af_can_available() -> bool {
    use nix::sys::socket::{socket, AddressFamily, SockFlag, SockProtocol, SockType};
    socket(
        AddressFamily::Can,
        SockType::Raw,
        SockFlag::SOCK_CLOEXEC,
        SockProtocol::CanRaw,
    )
    .is_ok()
}

/// The error of opening a CAN socket on `interface`, with what to do about it.
pub fn explain_open_error(interface: &str, e: io::Error) -> io::Error {
    let hint = if !af_can_available() {
        "this kernel has no CAN sockets (AF_CAN); load the `can` and `can-raw` modules, or run \
         inside the test VM (`cargo xtask vm -- …`)"
            .to_owned()
    } else if e.raw_os_error() == Some(19) {
        format!(
            "there is no interface `{interface}`; a virtual one: `ip link add dev {interface} \
             type vcan && ip link set {interface} up`"
        )
    } else {
        String::new()
    };
    let msg = if hint.is_empty() {
        format!("CAN interface `{interface}`: {e}")
    } else {
        format!("CAN interface `{interface}`: {e}: {hint}")
    };
    io::Error::new(e.kind(), msg)
}

/// Microseconds of the monotonic clock since the node started, divided by the time scale.
struct MonoClock(Instant, f64);

impl Clock for MonoClock {
    fn now_us(&mut self) -> u64 {
        (self.0.elapsed().as_secs_f64() * 1e6 / self.1) as u64
    }
}

/// The plant socket and what came through it.
struct PlantIo {
    socket: CanFdSocket,
    agent: u8,
    /// Frames go out as CAN FD with bit-rate switching.
    fd: bool,
    /// Sensor frames are packed: this is the first agent of ours.
    packed_first: Option<u8>,
    x: Option<[f32; N]>,
    /// The last command frame sent.
    q: Option<[f32; N]>,
    last_rx: Option<Instant>,
    tx_errors: u64,
}

impl PlantIo {
    /// This agent's state in a sensor frame `f` (its own, or its group's packed one).
    fn sensor(&self, f: &CanAnyFrame) -> Option<[f32; N]> {
        match self.packed_first {
            Some(first) => {
                let id = Kind::Sensor.id(first)?;
                if f.id() != embedded_can::Id::Standard(id) || f.is_remote_frame() {
                    return None;
                }
                plant_bus::decode_packed(first, self.agent, f.data())
            }
            None => match plant_bus::decode(f) {
                Some(PlantFrame::Sensor(a, x)) if a == self.agent => Some(x),
                _ => None,
            },
        }
    }

    /// Takes every waiting sensor frame; `true` if at least one came.
    fn drain(&mut self) -> bool {
        let mut got = false;
        while let Ok(f) = self.socket.read_frame() {
            if let Some(x) = self.sensor(&f) {
                self.x = Some(x);
                self.last_rx = Some(Instant::now());
                got = true;
            }
        }
        got
    }

    fn send(&mut self, f: Option<CanAnyFrame>) {
        let wire = f.and_then(|f| on_wire(&f, self.fd));
        if wire.is_none_or(|f| self.socket.write_frame(&f).is_err()) {
            self.tx_errors += 1;
        }
    }
}

/// The state sensor: the latest sensor frame.
struct BusSensor(Rc<RefCell<PlantIo>>);

/// No sensor frame has come yet.
#[derive(Debug)]
struct NoSample;

impl Sensor<N> for BusSensor {
    type Error = NoSample;
    fn read(&mut self) -> Result<[f32; N], NoSample> {
        let mut io = self.0.borrow_mut();
        io.drain();
        io.x.ok_or(NoSample)
    }
}

/// The actuators: one command frame per sample.
struct BusActuator(Rc<RefCell<PlantIo>>);

impl Actuator<N> for BusActuator {
    type Error = ();
    fn write(&mut self, q: &[f32; N]) -> Result<(), ()> {
        let mut io = self.0.borrow_mut();
        let agent = io.agent;
        let f = plant_bus::pair_frame(Kind::Command, agent, *q);
        let before = io.tx_errors;
        io.send(f);
        if io.tx_errors == before {
            io.q = Some(*q);
            Ok(())
        } else {
            Err(())
        }
    }
}

/// Runs the node until a signal (`stop` set) or the host's silence; the reason it stopped.
pub fn run(cfg: &NodeFile, stop: &Arc<AtomicBool>) -> io::Result<Stop> {
    let agent = cfg.node_config.agent;
    let iface = cfg.node.interface.as_str();
    let fd = cfg.node.fd();
    let bus = open_fd(iface)?;
    // Everything but the plant-bus frames (0x200..=0x3FF): value frames, status PDOs and
    // CANopen frames of whatever identifier plan.
    let plant_block = |base: u16| CanFilter::new_inverted(u32::from(base), 0x700);
    bus.set_filters(&[
        plant_block(plant_bus::SENSOR_BASE),
        plant_block(plant_bus::COMMAND_BASE),
    ])?;
    bus.set_join_filters(true)?;
    bus.set_error_filter(ERROR_CLASSES)?;
    bus.set_nonblocking(true)?;
    let plant = open_fd(iface)?;
    let packed_first = if cfg.node.packed_sensors() {
        plant_bus::packed_first(agent)
    } else {
        None
    };
    let sensor_id = Kind::Sensor
        .id(packed_first.unwrap_or(agent))
        .map_or(0, |id| u32::from(id.as_raw()));
    plant.set_filters(&[CanFilter::new(sensor_id, 0x7FF)])?;
    plant.set_nonblocking(true)?;
    let io = Rc::new(RefCell::new(PlantIo {
        socket: plant,
        agent,
        fd,
        packed_first,
        x: None,
        q: None,
        last_rx: None,
        tx_errors: 0,
    }));
    let mut node: LinuxNode = Node::new(
        &cfg.node_config,
        &cfg.controller,
        BusSocket {
            socket: bus,
            fd,
            faults: CanFaults::default(),
        },
        MonoClock(Instant::now(), cfg.node.time_scale),
        BusSensor(io.clone()),
        BusActuator(io.clone()),
    )
    .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
    if let Some(co) = &cfg.node.canopen {
        enable_canopen(&mut node, cfg, co)?;
        if packed_first.is_none() {
            // The sensor frame is RPDO18, the command frame TPDO3 (a packed sensor frame
            // carries 8 agents: no PDO of this node describes it).
            node.enable_plant_pdos();
        }
    }
    let h = Duration::from_secs_f64(cfg.wall_h());
    let host_timeout = Duration::from_secs_f64(cfg.node.host_timeout);
    let exit_on_stop = cfg.node.canopen.as_ref().is_some_and(|c| c.exit_on_stop);
    let stopped = |node: &LinuxNode| stop_commanded(node.canopen().map(|d| d.nmt()), exit_on_stop);
    log::info!("agent {agent}: on {iface}, waiting for the host's sensor frames");
    let waiting_since = Instant::now();
    let start_timeout = Duration::from_secs_f64(cfg.node.start_timeout());
    // Waiting for the first sensor frame; NMT, SDO and heartbeats go on meanwhile.
    let first = loop {
        if stop.load(Ordering::Relaxed) {
            return Ok(finish(&mut node, Stop::Signal));
        }
        node.service();
        report_can_faults(&mut node);
        serve_requests(&mut node, cfg);
        if stopped(&node) {
            return Ok(finish(&mut node, Stop::Commanded));
        }
        let now = Instant::now();
        if now.saturating_duration_since(waiting_since) > start_timeout {
            log::error!(
                "agent {agent}: no sensor frame within node.start_timeout = {} s: the run never began",
                start_timeout.as_secs_f64()
            );
            return Ok(finish(&mut node, Stop::NeverStarted));
        }
        if io.borrow_mut().drain() {
            break io.borrow().last_rx.unwrap_or(now);
        }
        std::thread::sleep(Duration::from_micros(200).min(h / 4));
    };
    log::info!("agent {agent}: first sensor frame, sampling every {h:?}");
    let start = first + h / 2;
    let mut k: u64 = 0;
    let mut ticks: u64 = 0;
    let mut late: u64 = 0;
    let reason = loop {
        let deadline = start + h.mul_f64(k as f64);
        let now = Instant::now();
        if deadline > now {
            std::thread::sleep(deadline - now);
        }
        if stop.load(Ordering::Relaxed) {
            break Stop::Signal;
        }
        io.borrow_mut().drain();
        let woke = Instant::now();
        let behind = woke.saturating_duration_since(deadline);
        if behind > h / 2 {
            late += 1;
            // A sample that missed its slot: counted in the status PDO and reported by EMCY
            // 0x6200 (deadline overrun).
            node.record_overrun();
        }
        node.tick();
        let (x, q) = {
            let io = io.borrow();
            (io.x, io.q)
        };
        node.plant_frames(x, q);
        report_can_faults(&mut node);
        serve_requests(&mut node, cfg);
        ticks += 1;
        if stopped(&node) {
            break Stop::Commanded;
        }
        let last_rx = io.borrow().last_rx.unwrap_or(first);
        if woke.saturating_duration_since(last_rx) > host_timeout {
            log::error!(
                "agent {agent}: no sensor frame for {:?} (host_timeout): the host is gone",
                woke.saturating_duration_since(last_rx)
            );
            break Stop::HostLost;
        }
        // Skip the samples a stall made us miss instead of running them in a burst.
        let elapsed = Instant::now().saturating_duration_since(start);
        k = (k + 1).max((elapsed.as_secs_f64() / h.as_secs_f64()).floor() as u64);
    };
    let st = node.stats();
    log::info!(
        "agent {agent}: {ticks} samples, {late} late (woke more than h/2 after the deadline), \
         {} frames received, {} stale link-samples, {} tx errors",
        st.frames_rx,
        st.stale_samples,
        st.tx_errors + u32::try_from(io.borrow().tx_errors).unwrap_or(u32::MAX)
    );
    Ok(finish(&mut node, reason))
}

/// The node's last words on the bus, by CANopen (docs/NETWORK.md §11): the host's silence is
/// EMCY `0x8250` ([`Fault::HostLost`]); a commanded or signalled stop is a last heartbeat
/// saying `STOPPED` (after an NMT stop the device is stopped; after a signal the node leaves
/// operational on its own), so the master sees the node go rather than fall silent.
fn finish(node: &mut LinuxNode, reason: Stop) -> Stop {
    let agent = node.agent();
    match reason {
        Stop::Commanded | Stop::Signal => {
            if reason == Stop::Commanded {
                log::info!("agent {agent}: the host commanded the end of the run (NMT stop)");
            }
            let id = node.canopen().map(|d| d.node_id());
            if let Some(f) = id.and_then(|id| {
                CoFrame::new(heartbeat_id(id), &[NmtState::Stopped.code()]).to_frame()
            }) {
                let _ = embedded_can::nb::Can::transmit(node.can_mut(), &f);
            }
        }
        Stop::HostLost | Stop::NeverStarted => node.report_fault(Fault::HostLost, 0),
    }
    log::info!("agent {agent}: stopped ({reason:?})");
    reason
}

/// Make the node a CANopen device and load its stored object dictionary, if there is one (a
/// stored set the node refuses is reported by EMCY `0x6300` and left aside).
fn enable_canopen<C: embedded_can::nb::Can, Clk: Clock, S: Sensor<N>, A: Actuator<N>>(
    node: &mut Node<C, Clk, S, A, N, N, MAX_NEIGHBOURS>,
    cfg: &NodeFile,
    co: &CanOpenSection,
) -> io::Result<()> {
    let identity = Identity {
        product: 1,
        revision: 1,
        ..Identity::default()
    };
    node.enable_canopen(
        &cfg.node_config,
        &cfg.controller,
        identity,
        co.self_starting,
        co.heartbeat_ms,
    )
    .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
    load_store(node, co);
    Ok(())
}

fn load_store<C: embedded_can::nb::Can, Clk: Clock, S: Sensor<N>, A: Actuator<N>>(
    node: &mut Node<C, Clk, S, A, N, N, MAX_NEIGHBOURS>,
    co: &CanOpenSection,
) {
    let Some(path) = &co.store else {
        return;
    };
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return,
        Err(e) => {
            log::error!("node.canopen.store `{path}`: {e}");
            return;
        }
    };
    if let Some(d) = node.canopen_mut() {
        match d.load(&bytes) {
            Ok(()) => log::info!("object dictionary loaded from {path}"),
            Err(a) => {
                log::error!(
                    "node.canopen.store `{path}`: refused (SDO abort {:#010x}); defaults kept",
                    a.code()
                );
                d.report(Fault::ConfigRejected, 0);
            }
        }
    }
}

/// The faults the bus socket's error frames raised, by EMCY (with a CANopen device; logged
/// either way).
fn report_can_faults(node: &mut LinuxNode) {
    let agent = node.agent();
    for (f, count) in node.can_mut().faults.take(Instant::now()) {
        log::warn!("agent {agent}: {f:?} (count {count})");
        node.report_fault(f, count);
    }
}

/// Store, restore and reset-node requests of the CANopen device, against the store file.
fn serve_requests<C: embedded_can::nb::Can, Clk: Clock, S: Sensor<N>, A: Actuator<N>>(
    node: &mut Node<C, Clk, S, A, N, N, MAX_NEIGHBOURS>,
    cfg: &NodeFile,
) {
    let Some(co) = &cfg.node.canopen else {
        return;
    };
    while let Some(r) = node.take_canopen_request() {
        let Some(path) = &co.store else {
            log::warn!("{r:?} requested but node.canopen.store is not set: nothing persists");
            continue;
        };
        match r {
            CanOpenRequest::Store => {
                let mut buf = vec![0u8; STORE_CAPACITY];
                let Some(n) = node.canopen().and_then(|d| d.save(&mut buf)) else {
                    continue;
                };
                let tmp = format!("{path}.tmp");
                let r = std::fs::write(&tmp, buf.get(..n).unwrap_or(&[]))
                    .and_then(|()| std::fs::rename(&tmp, path));
                match r {
                    Ok(()) => log::info!("object dictionary stored in {path} ({n} bytes)"),
                    Err(e) => log::error!("node.canopen.store `{path}`: {e}"),
                }
            }
            CanOpenRequest::Restore => match std::fs::remove_file(path) {
                Ok(()) => log::info!("{path} removed: defaults at the next start"),
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => log::error!("node.canopen.store `{path}`: {e}"),
            },
            CanOpenRequest::ResetNode => {
                // The stored set, row and plan included, is the node's for the next start.
                load_store(node, co);
                node.adopt();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use agent_node::canopen::od::{Setting, PARAM_BASE, SETTING_BASE};
    use agent_node::CanFrame;
    use controller_core::{ControllerConfig, Param};
    use socketcan::CanErrorFrame;

    /// A bus that takes every frame and delivers none.
    struct NoBus;

    impl embedded_can::nb::Can for NoBus {
        type Frame = CanFrame;
        type Error = embedded_can::ErrorKind;
        fn transmit(&mut self, _: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
            Ok(None)
        }
        fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
            Err(nb::Error::WouldBlock)
        }
    }

    struct Still;

    impl Sensor<N> for Still {
        type Error = ();
        fn read(&mut self) -> Result<[f32; N], ()> {
            Ok([0.0; N])
        }
    }

    impl Actuator<N> for Still {
        type Error = ();
        fn write(&mut self, _: &[f32; N]) -> Result<(), ()> {
            Ok(())
        }
    }

    type TestNode = Node<NoBus, MonoClock, Still, Still, N, N, MAX_NEIGHBOURS>;

    /// The process's start on `cfg`: the node, its CANopen device with the store file loaded,
    /// booted (pre-operational).
    fn start(cfg: &NodeFile) -> TestNode {
        let mut node = Node::new(
            &cfg.node_config,
            &cfg.controller,
            NoBus,
            MonoClock(Instant::now(), 1.0),
            Still,
            Still,
        )
        .expect("valid");
        let co = cfg.node.canopen.as_ref().expect("[node.canopen]");
        enable_canopen(&mut node, cfg, co).expect("device");
        node.service();
        node
    }

    /// A written graph row and identifier plan are stored in the file by `0x1010`, back after
    /// a restart (the node hears the stored row), and gone after `0x1011` and a restart.
    #[test]
    fn a_stored_row_and_plan_survive_a_restart_and_a_restore_removes_them() {
        let path = std::env::temp_dir().join(format!("node-linux-row-{}.co", std::process::id()));
        let _ = std::fs::remove_file(&path);
        let mut section = toml::from_str::<crate::config::NodeSection>(
            "agent = 4\nneighbours = [1, 3]\ninterface = \"vcan0\"\nnode_id = 4\n",
        )
        .expect("section");
        section.canopen = Some(CanOpenSection {
            store: Some(path.display().to_string()),
            heartbeat_ms: 0,
            self_starting: false,
            exit_on_stop: false,
        });
        let controller = ControllerConfig::<N> {
            neighbour_count: 2,
            h: 0.001,
            ..ControllerConfig::default()
        };
        let text = NodeFile::to_toml(&section, controller).expect("serializes");
        let cfg = NodeFile::parse(&text).expect("valid");
        let row = PARAM_BASE
            + Param::ALL
                .iter()
                .position(|p| *p == Param::Neighbours)
                .expect("row") as u16;
        let agents = SETTING_BASE
            + Setting::ALL
                .iter()
                .position(|s| *s == Setting::Agents)
                .expect("agents") as u16;
        let heard = |n: &TestNode| (0..3).map(|k| n.neighbour_agent(k)).collect::<Vec<_>>();

        let mut node = start(&cfg);
        assert_eq!(heard(&node), [Some(1), Some(3), None]);
        let d = node.canopen_mut().expect("device");
        // Agent 4 hears 2, 3 and 6 in a plan of 6 agents.
        d.write(agents, 0, &[6]).expect("plan");
        d.write(row, 3, &[6]).expect("entry 3");
        d.write(row, 1, &[2]).expect("entry 1");
        d.write(row, 0, &[3]).expect("count");
        d.write(0x1010, 1, b"save").expect("store");
        node.service();
        serve_requests(&mut node, &cfg);
        assert!(path.exists(), "stored");

        let mut node = start(&cfg);
        assert_eq!(
            heard(&node),
            [Some(2), Some(3), Some(6)],
            "restored at the start"
        );
        assert_eq!(node.ids().agents(), 6);
        // Another row written, not stored, then NMT reset node: the stored row again, and
        // nothing left pending, so a start runs.
        let d = node.canopen_mut().expect("device");
        d.write(row, 0, &[1]).expect("count");
        d.on_frame(agent_node::canopen::NMT_ID, &[0x81, 4], 0);
        node.service();
        serve_requests(&mut node, &cfg);
        assert_eq!(heard(&node), [Some(2), Some(3), Some(6)], "the stored row");
        assert_eq!(node.canopen().map(|d| d.graph_written()), Some(false));

        let mut node = start(&cfg);
        let d = node.canopen_mut().expect("device");
        d.write(0x1011, 1, b"load").expect("restore");
        node.service();
        serve_requests(&mut node, &cfg);
        assert!(!path.exists(), "the store file is removed");
        let node = start(&cfg);
        assert_eq!(
            heard(&node),
            [Some(1), Some(3), None],
            "the file's row again"
        );
        assert_eq!(node.ids(), &cfg.node_config.ids);
    }

    /// The error a kernel error frame of `class` with `data` decodes to.
    fn error(class: u32, data: &[u8]) -> CanError {
        CanErrorFrame::new_error(class, data)
            .expect("error frame")
            .into_error()
    }

    #[test]
    fn error_frames_raise_bus_off_at_the_restart_and_receive_overflow() {
        let rx_overflow = ControllerProblems::RX_OVERFLOW.bits();
        let tx_warning = ControllerProblems::TX_WARNING.bits();
        assert_eq!(faults_of(&error(CAN_ERR_RESTARTED, &[])), [Fault::BusOff]);
        assert_eq!(
            faults_of(&error(CAN_ERR_CRTL, &[0, rx_overflow])),
            [Fault::RxOverflow]
        );
        assert_eq!(
            faults_of(&error(
                CAN_ERR_RESTARTED | CAN_ERR_CRTL,
                &[0, rx_overflow | tx_warning]
            )),
            [Fault::BusOff, Fault::RxOverflow]
        );
        // Bus-off itself (nothing can be sent then), a warning, a transmit overflow: none.
        assert_eq!(faults_of(&error(CAN_ERR_BUSOFF, &[])), []);
        assert_eq!(faults_of(&error(CAN_ERR_CRTL, &[0, tx_warning])), []);
        let tx_overflow = ControllerProblems::TX_OVERFLOW.bits();
        assert_eq!(faults_of(&error(CAN_ERR_CRTL, &[0, tx_overflow])), []);
        // Every class the mapping reads is one the socket asks for.
        for class in [CAN_ERR_RESTARTED, CAN_ERR_CRTL] {
            assert_eq!(ERROR_CLASSES & class, class);
        }
    }

    #[test]
    fn only_an_nmt_stop_with_exit_on_stop_ends_the_run() {
        assert!(stop_commanded(Some(NmtState::Stopped), true));
        // A stopped node without the flag stays, as CiA 301 has it.
        assert!(!stop_commanded(Some(NmtState::Stopped), false));
        for s in [
            NmtState::Initialising,
            NmtState::PreOperational,
            NmtState::Operational,
        ] {
            assert!(!stop_commanded(Some(s), true), "{s:?}");
        }
        // No CANopen device: nothing commands a stop.
        assert!(!stop_commanded(None, true));
    }

    #[test]
    fn receive_overflow_emcys_are_inhibited_and_carry_the_count() {
        let overflow = error(CAN_ERR_CRTL, &[0, ControllerProblems::RX_OVERFLOW.bits()]);
        let restart = error(CAN_ERR_RESTARTED, &[]);
        let mut f = CanFaults::default();
        let t0 = Instant::now();
        f.raise(&overflow);
        f.raise(&restart);
        assert_eq!(f.take(t0), [(Fault::RxOverflow, 1), (Fault::BusOff, 1)]);
        f.raise(&overflow);
        f.raise(&overflow);
        assert_eq!(f.take(t0 + Duration::from_millis(500)), []);
        f.raise(&overflow);
        f.raise(&restart);
        assert_eq!(
            f.take(t0 + RX_OVERFLOW_EMCY_INHIBIT),
            [(Fault::RxOverflow, 4), (Fault::BusOff, 2)]
        );
        assert_eq!(f.take(t0 + 2 * RX_OVERFLOW_EMCY_INHIBIT), []);
    }
}
