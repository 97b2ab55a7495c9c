//! The example wiring's sensor, actuators, clock, watchdog and backup register; the only module
//! with `unsafe` (register fields the peripheral access crate marks unchecked, each with its
//! reason).
//!
//! * [`DriverEnable`]: the motor driver's enable (PA8), held in a critical-section cell so
//!   that the panic and hard-fault handlers can pull it low whatever owns it ([`driver_off`]).
//! * [`Encoder`]: a quadrature encoder on TIM2 (32-bit) in encoder mode 3 (both edges of both
//!   channels); the arithmetic is [`nucleo_g474re::scale::encoder_state`].
//! * [`PwmPair`]: the `m = 2` commands as locked-antiphase PWM duty on TIM3 CH1/CH2
//!   ([`nucleo_g474re::scale::duty`]); the node's write only keeps the command, the output
//!   gate's decision then applies it ([`PwmPair::apply`]).
//! * [`CycleClock`]: the DWT cycle counter extended to 64 bits, read as microseconds.
//! * [`Iwdg`]: the independent watchdog, started with [`nucleo_g474re::iwdg::IwdgSetting`].
//! * [`boot_count`]: this boot's number from the backup register `TAMP_BKP0R`.

use core::cell::RefCell;

use agent_node::Clock;
use cortex_m::{interrupt::Mutex, peripheral::DWT};
use nucleo_g474re::{iwdg::IwdgSetting, reset::next_boot};
use stm32g4xx_hal::{
    gpio::{Output, PushPull, PA8},
    rcc::Rcc,
    stm32::{IWDG, TAMP},
};

#[cfg(not(feature = "bench"))]
pub use motor::{Encoder, PwmPair};

/// Core clock [Hz]: HSE 24 MHz / 6 × 85 / 2.
pub const SYSCLK_HZ: u32 = 170_000_000;

/// The driver enable pin: push-pull, high = run.
pub type EnablePin = PA8<Output<PushPull>>;

/// The enable pin, reachable from the panic handler.
static DRIVER_ENABLE: Mutex<RefCell<Option<EnablePin>>> = Mutex::new(RefCell::new(None));

/// The handle of the driver enable once [`DriverEnable::install`]ed.
pub struct DriverEnable(());

impl DriverEnable {
    /// Drive the pin low and keep it where [`driver_off`] finds it.
    pub fn install(mut pin: EnablePin) -> Self {
        pin.set_low();
        cortex_m::interrupt::free(|cs| {
            if let Ok(mut p) = DRIVER_ENABLE.borrow(cs).try_borrow_mut() {
                *p = Some(pin);
            }
        });
        Self(())
    }

    /// High (driver enabled) or low.
    #[cfg_attr(feature = "bench", allow(dead_code))]
    pub fn set(&mut self, enabled: bool) {
        cortex_m::interrupt::free(|cs| {
            if let Ok(mut p) = DRIVER_ENABLE.borrow(cs).try_borrow_mut() {
                if let Some(p) = p.as_mut() {
                    if enabled {
                        p.set_high();
                    } else {
                        p.set_low();
                    }
                }
            }
        });
    }
}

/// Pull the driver enable low, wherever the firmware is (the panic handler's first act).
/// Interrupts are masked meanwhile; the cell is borrowed only inside such sections, so the
/// borrow cannot fail unless the panic came from inside one.
pub fn driver_off() {
    cortex_m::interrupt::free(|cs| {
        if let Ok(mut p) = DRIVER_ENABLE.borrow(cs).try_borrow_mut() {
            if let Some(p) = p.as_mut() {
                p.set_low();
            }
        }
    });
}

/// A hard fault (a panic ends in one too, through `udf`): the driver enable low, then stay
/// here above every task's priority until the watchdog resets the board (or the debugger
/// stops it). `unsafe` only because cortex-m-rt requires the handler to be declared so.
#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    driver_off();
    loop {
        cortex_m::asm::nop();
    }
}

/// Microseconds from the DWT cycle counter (which wraps every 25 s at 170 MHz: the clock is
/// read every sample, so every wrap is seen).
pub struct CycleClock {
    high: u64,
    last: u32,
}

impl CycleClock {
    /// The counter must already run (`DWT::enable_cycle_counter`).
    pub fn new() -> Self {
        Self {
            high: 0,
            last: DWT::cycle_count(),
        }
    }
}

impl Clock for CycleClock {
    fn now_us(&mut self) -> u64 {
        let now = DWT::cycle_count();
        if now < self.last {
            self.high += 1 << 32;
        }
        self.last = now;
        (self.high | u64::from(now)) / u64::from(SYSCLK_HZ / 1_000_000)
    }
}

/// The independent watchdog.
pub struct Iwdg {
    iwdg: IWDG,
}

impl Iwdg {
    /// Start it (from then on it cannot be stopped but by a reset) with `setting`: enable,
    /// unlock the registers, write `IWDG_PR` and `IWDG_RLR`, wait until both are taken, reload.
    pub fn start(iwdg: IWDG, setting: IwdgSetting) -> Self {
        iwdg.kr().write(|w| w.key().start());
        iwdg.kr().write(|w| w.key().unlock());
        iwdg.pr().write(|w| w.pr().set(setting.pr));
        iwdg.rlr().write(|w| w.rl().set(setting.rl));
        while iwdg.sr().read().bits() != 0 {}
        iwdg.kr().write(|w| w.key().feed());
        Self { iwdg }
    }

    /// Reload the counter.
    pub fn feed(&mut self) {
        self.iwdg.kr().write(|w| w.key().feed());
    }
}

/// This boot's number: `TAMP_BKP0R` read, advanced ([`next_boot`]) and written back. Enables
/// the PWR and RTC/TAMP register clocks and backup-domain write access on the way.
pub fn boot_count(tamp: &TAMP, rcc: &mut Rcc) -> u16 {
    rcc.unlock_rtc();
    rcc.apb1enr1().modify(|_, w| w.rtcapben().set_bit());
    let (stored, count) = next_boot(tamp.bkpr(0).read().bkp().bits());
    // SAFETY: a backup register holds any 32-bit value (RM0440 §38.6.6).
    tamp.bkpr(0).write(|w| unsafe { w.bkp().bits(stored) });
    count
}

/// The example wiring's encoder and PWM (not in the bench build).
#[cfg(not(feature = "bench"))]
mod motor {
    use agent_node::{Actuator, Sensor};
    use embedded_hal::pwm::SetDutyCycle;
    use nucleo_g474re::{
        config::{M, N},
        gate::GateOutput,
        scale::{duty, encoder_state, neutral_duty},
    };
    use stm32g4xx_hal::{rcc::Rcc, stm32::TIM2};

    use super::DriverEnable;

    /// TIM2 as a quadrature decoder.
    pub struct Encoder {
        tim: TIM2,
        last: Option<u32>,
    }

    impl Encoder {
        /// Clock TIM2, map CH1/CH2 to TI1/TI2 with a 4-sample input filter, encoder mode 3, run.
        /// The pins (PA0, PA1, AF1) are configured by the caller.
        pub fn new(tim: TIM2, rcc: &mut Rcc) -> Self {
            rcc.apb1enr1().modify(|_, w| w.tim2en().set_bit());
            tim.ccmr1_input().write(|w| {
                w.cc1s().ti1().cc2s().ti2();
                w.icf(0).fck_int_n4().icf(1).fck_int_n4()
            });
            tim.arr().write(|w| w.arr().set(u32::MAX));
            // SAFETY: SMS = 0b011 is "encoder mode 3" (RM0440 §29.4.3); SMS_3 stays 0.
            tim.smcr().write(|w| unsafe { w.sms().bits(0b011) });
            tim.cr1().modify(|_, w| w.cen().set_bit());
            Self { tim, last: None }
        }
    }

    impl Sensor<N> for Encoder {
        type Error = core::convert::Infallible;

        /// `x1` from the count (two's complement about the start position), `x2` from the counts
        /// moved since the previous sample.
        fn read(&mut self) -> Result<[f32; N], Self::Error> {
            let now = self.tim.cnt().read().cnt().bits();
            let x = encoder_state(now, self.last);
            self.last = Some(now);
            Ok(x)
        }
    }

    /// A command that is not a number.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct NonFiniteCommand;

    /// Two PWM channels, the node's last command and the driver enable.
    pub struct PwmPair<P1, P2> {
        ch1: P1,
        ch2: P2,
        q: [f32; M],
        enable: DriverEnable,
    }

    impl<P1: SetDutyCycle, P2: SetDutyCycle> PwmPair<P1, P2> {
        /// Both channels at the neutral duty (their outputs enabled by the caller only after
        /// this), the driver disabled.
        pub fn new(ch1: P1, ch2: P2, mut enable: DriverEnable) -> Self {
            enable.set(false);
            let mut p = Self {
                ch1,
                ch2,
                q: [0.0; M],
                enable,
            };
            p.neutral();
            p
        }

        /// The two channels (to start their outputs once the neutral duty is written).
        pub fn channels_mut(&mut self) -> (&mut P1, &mut P2) {
            (&mut self.ch1, &mut self.ch2)
        }

        fn neutral(&mut self) {
            let _ = self
                .ch1
                .set_duty_cycle(neutral_duty(self.ch1.max_duty_cycle()));
            let _ = self
                .ch2
                .set_duty_cycle(neutral_duty(self.ch2.max_duty_cycle()));
        }

        /// The output gate's decision for this sample. Disabling: the enable low first, then the
        /// neutral duty. Driving: the command's duty, then the enable high (TIM3 loads the duty at
        /// its next update, so the first PWM period after enabling may still be neutral).
        pub fn apply(&mut self, out: GateOutput) {
            if !out.enable {
                self.enable.set(false);
            }
            if out.drive {
                let d1 = duty(self.q[0], self.ch1.max_duty_cycle());
                let d2 = duty(self.q[1], self.ch2.max_duty_cycle());
                let _ = self.ch1.set_duty_cycle(d1);
                let _ = self.ch2.set_duty_cycle(d2);
            } else {
                self.neutral();
            }
            if out.enable {
                self.enable.set(true);
            }
        }
    }

    impl<P1: SetDutyCycle, P2: SetDutyCycle> Actuator<M> for PwmPair<P1, P2> {
        type Error = NonFiniteCommand;

        /// Keep the commands for [`PwmPair::apply`]; zero if one is not finite.
        fn write(&mut self, q: &[f32; M]) -> Result<(), Self::Error> {
            if q.iter().all(|v| v.is_finite()) {
                self.q = *q;
                Ok(())
            } else {
                self.q = [0.0; M];
                Err(NonFiniteCommand)
            }
        }
    }
}
