//! Node firmware for a NUCLEO-G474RE (STM32G474RE, Cortex-M4F at 170 MHz): `agent_node::Node`
//! unchanged over FDCAN1 at 1 Mbit/s, a quadrature encoder and two PWM outputs (or, with the
//! feature `bench`, the plant-bus sensor and command frames), released every sample period by
//! TIM6, guarded by the independent watchdog. RTIC 2 schedules the two hardware tasks; `defmt`
//! logs over RTT without ever blocking.
//!
//! The motor driver's enable (PA8) is low from the first instruction of `init` until the
//! output gate ([`nucleo_g474re::gate`]) arms it, is pulled low in every state that must not
//! drive and first thing in the panic handler. Pins, wiring, the gate's table and what to
//! expect on the bus: `docs/FIRMWARE.md`, "On a board". The node is a CiA 301 device: NMT
//! operational is its run command; its node-ID and parameters come from the stored
//! configuration's flash page ([`flash`], [`nucleo_g474re::param_page`]; CANopen `0x1010`
//! store, `0x1011` restore), else from the defaults of [`config`] as agent
//! [`config::DEFAULT_AGENT`] with EMCY `0x6300`. A configuration `Node::new` rejects leaves the
//! board in its fault state: driver disabled, FDCAN never leaves its configuration mode (no
//! frame sent or acknowledged), LD2 lit, the error logged by name, the watchdog never started.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod can;
#[allow(unsafe_code)]
mod flash;
#[allow(unsafe_code)]
mod io;

use defmt_rtt as _;
use nucleo_g474re::config;

/// The agent's sensor: the encoder, or the bench's sensor frames.
#[cfg(not(feature = "bench"))]
type BoardSensor = io::Encoder;
#[cfg(feature = "bench")]
type BoardSensor = nucleo_g474re::bench::BusSensor;

/// The agent's actuators: the PWM pair, or the bench's command frames.
#[cfg(not(feature = "bench"))]
type BoardActuator = Actuators;
#[cfg(feature = "bench")]
type BoardActuator = nucleo_g474re::bench::BusActuator;

#[cfg(feature = "bench")]
const _: () = assert!(
    config::N == 2 && config::M == 2,
    "plant-bus frames carry two states and two commands"
);

/// The node of this board.
type BoardNode = agent_node::Node<
    can::Fdcan1,
    io::CycleClock,
    BoardSensor,
    BoardActuator,
    { config::N },
    { config::M },
    { config::K },
>;

/// One TIM3 PWM channel.
#[cfg(not(feature = "bench"))]
type Channel<C> = stm32g4xx_hal::pwm::Pwm<
    stm32g4xx_hal::stm32::TIM3,
    C,
    stm32g4xx_hal::pwm::ComplementaryImpossible,
    stm32g4xx_hal::pwm::ActiveHigh,
    stm32g4xx_hal::pwm::ActiveHigh,
>;

/// TIM3 CH1 (PB4), CH2 (PB5); the driver enable (PA8) through [`io::DriverEnable`].
#[cfg(not(feature = "bench"))]
type Actuators = io::PwmPair<Channel<stm32g4xx_hal::pwm::C1>, Channel<stm32g4xx_hal::pwm::C2>>;

/// Ticks between two status lines (1 s at `h = 1 ms`).
const LOG_EVERY: u32 = 1_000_000 / config::SAMPLE_PERIOD_US;

/// Cycles of `Node::tick` (DWT) since the last status line.
#[derive(Default)]
struct Cycles {
    last: u32,
    max: u32,
    sum: u64,
    count: u32,
}

impl Cycles {
    fn record(&mut self, c: u32) {
        self.last = c;
        self.max = self.max.max(c);
        self.sum += u64::from(c);
        self.count += 1;
    }

    fn mean(&self) -> u32 {
        u32::try_from(self.sum / u64::from(self.count.max(1))).unwrap_or(u32::MAX)
    }
}

/// The board's own state beside the node: output gate, run command, leader freshness,
/// bus-off recovery ([`nucleo_g474re::board::BoardLogic`]), and on the bench the host's
/// silence (its EMCY goes out once per silence).
struct Board {
    logic: nucleo_g474re::board::BoardLogic,
    /// The agent the board booted as (its plant-bus frames).
    #[cfg(feature = "bench")]
    agent: u8,
    /// The node's adoptions of a node-ID, graph row or plan when the acceptance filters were
    /// set (`Node::adoptions`); another one over the bus restarts the board.
    adoptions: u16,
    #[cfg(feature = "bench")]
    host_watch: nucleo_g474re::bench::HostWatch,
}

/// The panic handler: the driver enable low before anything else, then the location over RTT
/// and a hard fault (the debugger stops there; without one the watchdog resets the board). The
/// message is not formatted: that would link `core::fmt` (about 1.5 KiB of the 64 KiB budget).
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    io::driver_off();
    match info.location() {
        Some(l) => defmt::error!("panic at {}:{}", l.file(), l.line()),
        None => defmt::error!("panic"),
    }
    cortex_m::asm::udf()
}

#[rtic::app(device = stm32g4xx_hal::stm32, peripherals = true)]
mod app {
    use agent_node::{
        canopen::{Fault, Identity},
        node::CanOpenRequest,
    };
    use cortex_m::peripheral::DWT;
    use nucleo_g474re::{
        board::BoardLogic,
        bus_off::Action,
        can_setup,
        iwdg::{IwdgSetting, LSI_HZ},
        param_page::{self, Job, Jobs, ParamFlash, Rejection},
        reset::{heartbeat_word, ResetFlags},
    };
    #[cfg(not(feature = "bench"))]
    use stm32g4xx_hal::pwm::PwmExt;
    use stm32g4xx_hal::{
        can::CanExt,
        gpio::GpioExt,
        hal_02::timer::CountDown,
        pwr::{PwrExt, VoltageScale},
        rcc::{Config, PllConfig, PllMDiv, PllNMul, PllRDiv, PllSrc, RccExt},
        stm32::TIM6,
        time::{ExtU32, RateExtU32},
        timer::{CountDownTimer, Event, Timer},
    };

    use super::{can, config, flash, io, Board, BoardNode, Cycles, LOG_EVERY};

    #[shared]
    struct Shared {
        #[lock_free]
        node: Option<BoardNode>,
        /// Store, restore and reset for the idle task.
        jobs: Jobs,
    }

    #[local]
    struct Local {
        page: flash::ParamPage,
        timer: Option<CountDownTimer<TIM6>>,
        watchdog: Option<io::Iwdg>,
        board: Board,
        cycles: Cycles,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let mut cp = cx.core;
        // The driver enable first: PA8 push-pull low (from reset until here it is an analog
        // input; the driver's enable input needs its pull-down, docs/FIRMWARE.md §7).
        let mut rcc = dp.RCC.constrain();
        let gpioa = dp.GPIOA.split(&mut rcc);
        let enable = io::DriverEnable::install(gpioa.pa8.into_push_pull_output());

        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
        let pll = PllConfig {
            mux: PllSrc::HSE(24.MHz()),
            m: PllMDiv::DIV_6,
            n: PllNMul::MUL_85,
            r: Some(PllRDiv::DIV_2),
            q: None,
            p: None,
        };
        let pwr = dp
            .PWR
            .constrain()
            .vos(VoltageScale::Range1 { enable_boost: true })
            .freeze();
        let mut rcc = rcc.freeze(Config::pll().pll_cfg(pll).boost(true), pwr);
        let flags = ResetFlags::from_csr(rcc.csr().read().bits());
        rcc.csr().modify(|_, w| w.rmvf().set_bit());
        let boot_count = io::boot_count(&dp.TAMP, &mut rcc);
        defmt::info!(
            "sysclk {} Hz; boot {}, reset by {} (RCC_CSR flags {=u8:#x})",
            rcc.clocks.sys_clk.raw(),
            boot_count,
            flags.cause(),
            flags.bits()
        );

        let gpiob = dp.GPIOB.split(&mut rcc);
        let mut led = gpioa.pa5.into_push_pull_output();
        #[cfg(not(feature = "bench"))]
        let (sensor, actuators) = {
            let _encoder_a = gpioa.pa0.into_alternate::<1>();
            let _encoder_b = gpioa.pa1.into_alternate::<1>();
            let encoder = io::Encoder::new(dp.TIM2, &mut rcc);
            let (ch1, ch2) = dp.TIM3.pwm(
                (gpiob.pb4.into_alternate(), gpiob.pb5.into_alternate()),
                config::PWM_HZ.Hz(),
                &mut rcc,
            );
            // Both duties neutral (TIM3 starts at 0 %: full reverse in locked antiphase), then
            // the channels' outputs, the driver still disabled.
            let mut pair = io::PwmPair::new(ch1, ch2, enable);
            let (c1, c2) = pair.channels_mut();
            c1.enable();
            c2.enable();
            (encoder, pair)
        };
        #[cfg(feature = "bench")]
        let (sensor, actuators) = {
            // No driver on the bench: the enable stays low.
            let _ = (enable, gpiob);
            (
                nucleo_g474re::bench::BusSensor::new(
                    config::SAMPLE_PERIOD_US,
                    config::NODE.stale_timeout_us,
                ),
                nucleo_g474re::bench::BusActuator::default(),
            )
        };
        let fdcan = dp.FDCAN1.fdcan(
            gpioa.pa12.into_alternate(),
            gpioa.pa11.into_alternate(),
            &mut rcc,
        );

        // The stored configuration decides which agent of the plan this board is.
        let page = flash::ParamPage::new(dp.FLASH);
        let boot = param_page::boot_config(page.page(), config::in_plan, config::DEFAULT_AGENT);
        // The compiled defaults of that agent (what 0x1011 restores); the stored node-ID,
        // graph row and plan replace them once the device has loaded the page (below).
        let node_cfg = config::node(boot.agent).unwrap_or(config::NODE);
        let controller = config::controller_of(boot.agent).unwrap_or_else(config::controller);
        match boot.rejected {
            None => defmt::info!("stored configuration: agent {}", boot.agent),
            Some(r) => defmt::warn!(
                "stored configuration not used ({}): defaults, agent {}",
                r,
                boot.agent
            ),
        }
        let mut board = Board {
            logic: BoardLogic::new(
                can_setup::uses_leader(&node_cfg, controller.pinned),
                config::SAMPLE_PERIOD_US,
                node_cfg.stale_timeout_us,
            ),
            #[cfg(feature = "bench")]
            agent: node_cfg.agent,
            adoptions: 0,
            #[cfg(feature = "bench")]
            host_watch: nucleo_g474re::bench::HostWatch::new(),
        };
        let watchdog_setting = IwdgSetting::for_timeout(config::WATCHDOG_US, LSI_HZ);
        let node = match (config::wiring_error(), watchdog_setting) {
            (Some(e), _) => {
                defmt::error!("config.rs: wiring rejected: {}", e);
                None
            }
            (None, None) => {
                defmt::error!(
                    "config.rs: wiring rejected: {}",
                    config::WiringError::Watchdog
                );
                None
            }
            (None, Some(_)) => {
                let bus = can::configure(fdcan);
                let identity = Identity {
                    product: 1,
                    revision: 1,
                    ..Identity::default()
                };
                agent_node::Node::new(
                    &node_cfg,
                    &controller,
                    bus,
                    io::CycleClock::new(),
                    sensor,
                    actuators,
                )
                .ok()
                .and_then(|mut node| {
                    node.enable_canopen(
                        &node_cfg,
                        &controller,
                        identity,
                        false,
                        config::CANOPEN_HEARTBEAT_MS,
                    )
                    .ok()?;
                    Some(node)
                })
            }
        };
        let (Some(mut node), Some(setting)) = (node, watchdog_setting) else {
            let _ = embedded_hal::digital::OutputPin::set_high(&mut led);
            defmt::error!("fault state: outputs off, no bus traffic");
            return (
                Shared {
                    node: None,
                    jobs: Jobs::new(),
                },
                Local {
                    page,
                    timer: None,
                    watchdog: None,
                    board,
                    cycles: Cycles::default(),
                },
            );
        };

        let mut rejected = boot.rejected;
        if let (Some(stored), Some(d)) = (boot.stored, node.canopen_mut()) {
            if let Err(a) = d.load(stored) {
                defmt::error!(
                    "stored configuration refused (SDO abort {=u32:#x}): defaults",
                    a.code()
                );
                rejected = Some(Rejection::Refused);
            }
        }
        // The node-ID, graph row and plan as loaded: the acceptance filters and the board's
        // logic follow them now, the node adopts them at its boot-up (`node.service` below).
        let (mut node_cfg, mut controller) = (node_cfg, controller);
        if let Some(d) = node.canopen() {
            node_cfg.graph_from(&d.store, &mut controller);
        }
        node.can_mut()
            .listen(&node_cfg, controller.neighbour_count, controller.pinned);
        board.logic = BoardLogic::new(
            can_setup::uses_leader(&node_cfg, controller.pinned),
            config::SAMPLE_PERIOD_US,
            node_cfg.stale_timeout_us,
        );
        #[cfg(feature = "bench")]
        {
            board.agent = node_cfg.agent;
        }
        node.set_boot_count(heartbeat_word(boot_count, flags));
        node.can_mut().join_bus();
        // Boot-up message, pre-operational; then the EMCY of a configuration not used.
        node.service();
        // What the filters were set for is what the node adopted at its boot-up.
        board.adoptions = node.adoptions();
        if let (Some(r), Some(d)) = (rejected, node.canopen_mut()) {
            d.report(Fault::ConfigRejected, r.code());
        }
        let watchdog = io::Iwdg::start(dp.IWDG, setting);
        let mut timer =
            Timer::new(dp.TIM6, &rcc.clocks).start_count_down(config::SAMPLE_PERIOD_US.micros());
        timer.listen(Event::TimeOut);
        let agent = agent_node::wire::Source::Agent(node_cfg.agent);
        defmt::info!(
            "agent {} (CANopen node-ID {}, value id {=u16:#x}, heartbeat id {=u16:#x}) runs every {} us; pre-operational; driver enabled after an NMT start with fresh sensor and leader",
            node_cfg.agent,
            node_cfg.agent,
            node_cfg.ids.value_id(agent).unwrap_or(0),
            node_cfg.ids.heartbeat_id(node_cfg.agent).unwrap_or(0),
            config::SAMPLE_PERIOD_US
        );
        (
            Shared {
                node: Some(node),
                jobs: Jobs::new(),
            },
            Local {
                page,
                timer: Some(timer),
                watchdog: Some(watchdog),
                board,
                cycles: Cycles::default(),
            },
        )
    }

    /// The flash work of the CANopen store (`0x1010`) and restore (`0x1011`), then a reset
    /// node's restart: here, at the lowest priority, so that the control task keeps its period
    /// (and feeds the watchdog) during a page erase of some 20 ms (bank 2 is erased while the
    /// code runs from bank 1).
    #[idle(shared = [jobs], local = [page])]
    fn idle(mut cx: idle::Context) -> ! {
        loop {
            match cx.shared.jobs.lock(Jobs::take) {
                Some(Job::Store(s)) => match param_page::store(cx.local.page, s.as_slice()) {
                    Ok(()) => defmt::info!("configuration stored ({} bytes)", s.as_slice().len()),
                    Err(e) => defmt::error!("configuration not stored: {}", e),
                },
                Some(Job::Erase) => match cx.local.page.erase() {
                    Ok(()) => {
                        defmt::info!("stored configuration erased: defaults at the next boot")
                    }
                    Err(e) => defmt::error!("stored configuration not erased: {}", e),
                },
                Some(Job::Reset) => {
                    defmt::info!("reset node: restarting");
                    cortex_m::peripheral::SCB::sys_reset();
                }
                None => cortex_m::asm::wfi(),
            }
        }
    }

    /// Released by TIM6 every sample period: bus-off recovery, one `Node::tick` (timed), the
    /// output gate, the outputs; the watchdog is fed only here and only when the step ended
    /// before the next release, so a control task that stops being released, or is late five
    /// periods in a row, resets the board.
    #[task(binds = TIM6_DACUNDER, shared = [node, jobs], local = [timer, watchdog, board, cycles])]
    fn control(mut cx: control::Context) {
        let (Some(node), Some(timer), Some(watchdog)) =
            (cx.shared.node, cx.local.timer, cx.local.watchdog)
        else {
            return;
        };
        let board = cx.local.board;
        timer.clear_interrupt(Event::TimeOut);
        if board.logic.before_tick(node.can().bus_off()) == Action::Restart {
            node.can_mut().restart();
            defmt::warn!(
                "FDCAN1 bus-off ({} so far): driver disabled, recovering after 128 x 11 recessive bits",
                board.logic.bus_off().bus_offs()
            );
        }
        #[cfg(feature = "bench")]
        {
            let x = node.can_mut().take_sensor();
            node.sensor_mut().offer(x);
        }
        let start = DWT::cycle_count();
        let tick = node.tick();
        let cycles = cx.local.cycles;
        cycles.record(DWT::cycle_count().wrapping_sub(start));

        #[cfg(not(feature = "bench"))]
        let sensor_fresh = true; // the encoder cannot fail a read
        #[cfg(feature = "bench")]
        let sensor_fresh = node.sensor_mut().is_fresh();
        let leader_heard = node.can_mut().take_leader_heard();
        let operational = node.canopen().is_some_and(|d| d.outputs_enabled());
        let out = board.logic.after_tick(
            operational,
            tick.state,
            node.supervisor().policy_in_force(),
            leader_heard,
            sensor_fresh,
        );
        #[cfg(not(feature = "bench"))]
        node.actuator_mut().apply(out);
        #[cfg(feature = "bench")]
        {
            use agent_node::plant_bus::{self, Kind};
            let agent = board.agent;
            let q = node.actuator().command(out.drive);
            let _ = node
                .can_mut()
                .send(plant_bus::pair_frame(Kind::Command, agent, q));
            let lost = nucleo_g474re::bench::host_lost(node.sensor_mut());
            if board.host_watch.update(lost) {
                node.report_fault(Fault::HostLost, 0);
            }
        }
        // The next release already came: this step was late. The watchdog is fed only after a
        // step that ended in time (five late in a row reset the board).
        let late = timer.wait().is_ok();
        if late {
            node.record_overrun();
        }
        if board.logic.step_ended(late) {
            watchdog.feed();
        }
        // The CANopen device's requests: the flash and the restart go to the idle task.
        while let Some(r) = node.take_canopen_request() {
            match r {
                CanOpenRequest::Store => {
                    let queued = cx
                        .shared
                        .jobs
                        .lock(|j| j.store_with(|buf| node.canopen().and_then(|d| d.save(buf))));
                    if !queued {
                        defmt::error!("0x1010 store: the dictionary does not fit");
                    }
                }
                CanOpenRequest::Restore => cx.shared.jobs.lock(Jobs::erase),
                CanOpenRequest::ResetNode => cx.shared.jobs.lock(Jobs::reset),
            }
        }
        if node.adoptions() != board.adoptions {
            // A reset communication adopted another node-ID, graph row or plan: the
            // acceptance filters are another's, so the board restarts as the stored
            // configuration says.
            cx.shared.jobs.lock(Jobs::reset);
        }
        if cycles.count >= LOG_EVERY {
            let st = node.stats();
            let (tec, rec) = node.can().error_counters();
            defmt::info!(
                "t = {} us, {}: gate {} (enables {}), step {} cycles (mean {}, max {}), late steps {}, overruns {}, u = {}, rx {} accepted {} heartbeats {}, stale {} missing {}, tx busy {} err {}, fifo overruns {}, TEC {} REC {}, bus-off {} recovered {}",
                tick.now_us,
                tick.state,
                board.logic.gate().state(),
                board.logic.gate().enables(),
                cycles.last,
                cycles.mean(),
                cycles.max,
                board.logic.late_steps(),
                st.overruns,
                tick.output.u,
                st.frames_rx,
                st.accepted,
                st.heartbeats_rx,
                st.stale_samples,
                st.missing_samples,
                st.tx_busy,
                st.tx_errors,
                node.can().overruns(),
                tec,
                rec,
                board.logic.bus_off().bus_offs(),
                board.logic.bus_off().recoveries()
            );
            *cycles = Cycles::default();
        }
    }

    /// FIFO 0 holds a new frame: the node takes it now, time-stamped closer to its arrival.
    #[task(binds = FDCAN1_IT0, shared = [node])]
    fn can_rx(cx: can_rx::Context) {
        if let Some(node) = cx.shared.node {
            node.can_mut().clear_rx_interrupt();
            node.poll_rx();
        }
    }
}
