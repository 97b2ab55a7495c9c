//! Node firmware for a NUCLEO-G474RE (STM32G474RE, Cortex-M4F at 170 MHz): `agent_node::Node`
//! unchanged over FDCAN1 at 1 Mbit/s, a quadrature encoder and two PWM outputs, released every
//! sample period by TIM6, guarded by the independent watchdog. RTIC 2 schedules the two
//! hardware tasks; `defmt` logs over RTT.
//!
//! Pins, wiring and what to expect on the bus: `docs/FIRMWARE.md`, "On a board". The
//! configuration is compiled in from [`config`]; a rejected one leaves the board in its fault
//! state: driver disabled, FDCAN never leaves its configuration mode (no frame sent or
//! acknowledged), LD2 lit, the error logged by name, the watchdog never started.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod can;
mod config;
#[allow(unsafe_code)]
mod io;

use defmt_rtt as _;
use panic_probe as _;

/// The node of this board.
type BoardNode = agent_node::Node<
    can::Fdcan1,
    io::CycleClock,
    io::Encoder,
    Actuators,
    { config::N },
    { config::M },
    { config::K },
>;

/// One TIM3 PWM channel.
type Channel<C> = stm32g4xx_hal::pwm::Pwm<
    stm32g4xx_hal::stm32::TIM3,
    C,
    stm32g4xx_hal::pwm::ComplementaryImpossible,
    stm32g4xx_hal::pwm::ActiveHigh,
    stm32g4xx_hal::pwm::ActiveHigh,
>;

/// TIM3 CH1 (PB4), CH2 (PB5) and the driver enable (PA8).
type Actuators = io::PwmPair<
    Channel<stm32g4xx_hal::pwm::C1>,
    Channel<stm32g4xx_hal::pwm::C2>,
    stm32g4xx_hal::gpio::PA8<stm32g4xx_hal::gpio::Output<stm32g4xx_hal::gpio::PushPull>>,
>;

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

#[rtic::app(device = stm32g4xx_hal::stm32, peripherals = true)]
mod app {
    use cortex_m::peripheral::DWT;
    use stm32g4xx_hal::{
        can::CanExt,
        gpio::GpioExt,
        independent_watchdog::IndependentWatchdog,
        pwm::PwmExt,
        pwr::{PwrExt, VoltageScale},
        rcc::{Config, PllConfig, PllMDiv, PllNMul, PllRDiv, PllSrc, RccExt},
        stm32::TIM6,
        time::{ExtU32, RateExtU32},
        timer::{CountDownTimer, Event, Timer},
    };

    use super::{can, config, io, Actuators, BoardNode, Cycles, LOG_EVERY};

    #[shared]
    struct Shared {
        #[lock_free]
        node: Option<BoardNode>,
    }

    #[local]
    struct Local {
        timer: Option<CountDownTimer<TIM6>>,
        watchdog: Option<IndependentWatchdog>,
        cycles: Cycles,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let mut cp = cx.core;
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
        let mut rcc = dp
            .RCC
            .constrain()
            .freeze(Config::pll().pll_cfg(pll).boost(true), pwr);
        let csr = rcc.csr().read();
        defmt::info!(
            "sysclk {} Hz; reset by: watchdog {}, pin {}, brown-out {}, software {}",
            rcc.clocks.sys_clk.raw(),
            csr.iwdgrstf().bit_is_set(),
            csr.pinrstf().bit_is_set(),
            csr.borrstf().bit_is_set(),
            csr.sftrstf().bit_is_set()
        );
        rcc.csr().modify(|_, w| w.rmvf().set_bit());

        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let mut led = gpioa.pa5.into_push_pull_output();
        let _encoder_a = gpioa.pa0.into_alternate::<1>();
        let _encoder_b = gpioa.pa1.into_alternate::<1>();
        let encoder = io::Encoder::new(dp.TIM2, &mut rcc);
        let (mut ch1, mut ch2) = dp.TIM3.pwm(
            (gpiob.pb4.into_alternate(), gpiob.pb5.into_alternate()),
            config::PWM_HZ.Hz(),
            &mut rcc,
        );
        // The outputs run from here (at 50 %, zero command); the driver enable gates them.
        ch1.enable();
        ch2.enable();
        let actuators: Actuators = io::PwmPair::new(ch1, ch2, gpioa.pa8.into_push_pull_output());
        let fdcan = dp.FDCAN1.fdcan(
            gpioa.pa12.into_alternate(),
            gpioa.pa11.into_alternate(),
            &mut rcc,
        );

        let controller = config::controller();
        let node = match config::wiring_error() {
            Some(e) => {
                defmt::error!("config.rs: wiring rejected: {}", e);
                None
            }
            None => {
                let bus = can::configure(
                    fdcan,
                    &config::NODE,
                    controller.neighbour_count,
                    controller.pinned,
                );
                agent_node::Node::new(
                    &config::NODE,
                    &controller,
                    bus,
                    io::CycleClock::new(),
                    encoder,
                    actuators,
                )
                .ok()
            }
        };
        let Some(mut node) = node else {
            let _ = embedded_hal::digital::OutputPin::set_high(&mut led);
            defmt::error!("fault state: outputs off, no bus traffic");
            return (
                Shared { node: None },
                Local {
                    timer: None,
                    watchdog: None,
                    cycles: Cycles::default(),
                },
            );
        };

        node.can_mut().join_bus();
        node.actuator_mut().arm();
        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.start(config::WATCHDOG_US.micros());
        let mut timer =
            Timer::new(dp.TIM6, &rcc.clocks).start_count_down(config::SAMPLE_PERIOD_US.micros());
        timer.listen(Event::TimeOut);
        let agent = agent_node::wire::Source::Agent(config::NODE.agent);
        defmt::info!(
            "agent {} (value id {=u16:#x}, heartbeat id {=u16:#x}) runs every {} us",
            config::NODE.agent,
            config::NODE.ids.value_id(agent).unwrap_or(0),
            config::NODE
                .ids
                .heartbeat_id(config::NODE.agent)
                .unwrap_or(0),
            config::SAMPLE_PERIOD_US
        );
        (
            Shared { node: Some(node) },
            Local {
                timer: Some(timer),
                watchdog: Some(watchdog),
                cycles: Cycles::default(),
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// Released by TIM6 every sample period: one `Node::tick`, timed; the watchdog is fed only
    /// here, so a control task that stops being released resets the board. A bus-off FDCAN
    /// latches the node's fault state (outputs zero) until the board is reset.
    #[task(binds = TIM6_DACUNDER, shared = [node], local = [timer, watchdog, cycles, bus_off: bool = false])]
    fn control(cx: control::Context) {
        let (Some(node), Some(timer), Some(watchdog)) =
            (cx.shared.node, cx.local.timer, cx.local.watchdog)
        else {
            return;
        };
        timer.clear_interrupt(Event::TimeOut);
        if !*cx.local.bus_off && node.can().bus_off() {
            *cx.local.bus_off = true;
            defmt::error!("FDCAN1 bus-off: node latched in its fault state");
            node.enter_fault();
        }
        let start = DWT::cycle_count();
        let tick = node.tick();
        let cycles = cx.local.cycles;
        cycles.record(DWT::cycle_count().wrapping_sub(start));
        watchdog.feed();
        if cycles.count >= LOG_EVERY {
            let st = node.stats();
            let (tec, rec) = node.can().error_counters();
            defmt::info!(
                "t = {} us, {}: step {} cycles (mean {}, max {}), overruns {}, u = {}, rx {} accepted {} heartbeats {}, stale {} missing {}, tx busy {} err {}, fifo overruns {}, TEC {} REC {}",
                tick.now_us,
                tick.state,
                cycles.last,
                cycles.mean(),
                cycles.max,
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
                rec
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
