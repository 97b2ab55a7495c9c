//! The example wiring's sensor, actuators and clock; the only module with `unsafe` (one
//! register field the peripheral access crate marks unchecked).
//!
//! * [`Encoder`]: a quadrature encoder on TIM2 (32-bit) in encoder mode 3 (both edges of both
//!   channels), `x1` = counts × `POSITION_PER_COUNT`, `x2` = the count difference over one
//!   sample period.
//! * [`PwmPair`]: the `m = 2` commands as locked-antiphase PWM duty on TIM3 CH1/CH2
//!   (`q = 0` → 50 %, `±COMMAND_FULL_SCALE` → 100 % / 0 %), and a driver-enable output held
//!   low until the node runs.
//! * [`CycleClock`]: the DWT cycle counter extended to 64 bits, read as microseconds.

use agent_node::{Actuator, Clock, Sensor};
use cortex_m::peripheral::DWT;
use embedded_hal::{digital::OutputPin, pwm::SetDutyCycle};
use stm32g4xx_hal::{rcc::Rcc, stm32::TIM2};

use crate::config::{COMMAND_FULL_SCALE, M, N, POSITION_PER_COUNT, SAMPLE_PERIOD_US};

/// Core clock [Hz]: HSE 24 MHz / 6 × 85 / 2.
pub const SYSCLK_HZ: u32 = 170_000_000;

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

    fn count(&self) -> u32 {
        self.tim.cnt().read().cnt().bits()
    }
}

impl Sensor<N> for Encoder {
    type Error = core::convert::Infallible;

    /// `x1` from the count (two's complement about the start position), `x2` from the counts
    /// moved since the previous sample.
    fn read(&mut self) -> Result<[f32; N], Self::Error> {
        let now = self.count();
        let moved = self.last.map_or(0, |l| now.wrapping_sub(l) as i32);
        self.last = Some(now);
        let x1 = now as i32 as f32 * POSITION_PER_COUNT;
        let x2 = moved as f32 * POSITION_PER_COUNT / (SAMPLE_PERIOD_US as f32 * 1e-6);
        Ok([x1, x2])
    }
}

/// A command that is not a number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NonFiniteCommand;

/// Two PWM channels and the driver's enable line.
pub struct PwmPair<P1, P2, E> {
    ch1: P1,
    ch2: P2,
    enable: E,
}

impl<P1: SetDutyCycle, P2: SetDutyCycle, E: OutputPin> PwmPair<P1, P2, E> {
    /// Both channels at 50 % (zero command), the driver still disabled.
    pub fn new(ch1: P1, ch2: P2, enable: E) -> Self {
        let mut p = Self { ch1, ch2, enable };
        p.neutral();
        p
    }

    fn neutral(&mut self) {
        let _ = self.ch1.set_duty_cycle_fraction(1, 2);
        let _ = self.ch2.set_duty_cycle_fraction(1, 2);
    }

    /// Enable the driver: the commands act from now on.
    pub fn arm(&mut self) {
        let _ = self.enable.set_high();
    }
}

/// Duty of one command on a channel whose full duty is `max`.
fn duty(q: f32, max: u16) -> u16 {
    let half = (q / COMMAND_FULL_SCALE).clamp(-1.0, 1.0) * 0.5 + 0.5;
    (half * f32::from(max)) as u16
}

impl<P1: SetDutyCycle, P2: SetDutyCycle, E: OutputPin> Actuator<M> for PwmPair<P1, P2, E> {
    type Error = NonFiniteCommand;

    /// Both duties, or both at 50 % if a command is not finite.
    fn write(&mut self, q: &[f32; M]) -> Result<(), Self::Error> {
        if !q.iter().all(|v| v.is_finite()) {
            self.neutral();
            return Err(NonFiniteCommand);
        }
        let d1 = duty(q[0], self.ch1.max_duty_cycle());
        let d2 = duty(q[1], self.ch2.max_duty_cycle());
        let _ = self.ch1.set_duty_cycle(d1);
        let _ = self.ch2.set_duty_cycle(d2);
        Ok(())
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
