//! The example wiring's arithmetic, apart from the registers: encoder counts to the state
//! `x_i`, commands to PWM duty.
//!
//! * Encoder (TIM2, 32-bit, encoder mode 3): `x1 = count × POSITION_PER_COUNT`, the count read
//!   as two's complement about the start position; `x2 = (count − previous count) ×
//!   POSITION_PER_COUNT / h`, the difference taken modulo 2³² so a wrap of the counter is a
//!   small step, not a jump.
//! * PWM (TIM3 CH1/CH2, locked antiphase): duty `= (clamp(q / COMMAND_FULL_SCALE, −1, 1) / 2 +
//!   1/2) × max`, so `q = 0` is the neutral 50 % (zero mean voltage across the motor) and
//!   `±COMMAND_FULL_SCALE` is 100 % / 0 %; a command that is not finite gives the neutral duty.

use crate::config::{COMMAND_FULL_SCALE, POSITION_PER_COUNT, SAMPLE_PERIOD_US};

/// `x_i = [x1, x2]` from the encoder count now and at the previous sample (`None` at the
/// first sample: `x2 = 0`).
pub fn encoder_state(now: u32, last: Option<u32>) -> [f32; 2] {
    let moved = last.map_or(0, |l| now.wrapping_sub(l) as i32);
    let x1 = now as i32 as f32 * POSITION_PER_COUNT;
    let x2 = moved as f32 * POSITION_PER_COUNT / (SAMPLE_PERIOD_US as f32 * 1e-6);
    [x1, x2]
}

/// The neutral duty (50 %) of a channel whose full duty is `max`.
pub const fn neutral_duty(max: u16) -> u16 {
    max / 2
}

/// The duty of command `q` on a channel whose full duty is `max`; neutral for a command that
/// is not finite.
pub fn duty(q: f32, max: u16) -> u16 {
    if !q.is_finite() {
        return neutral_duty(max);
    }
    let half = (q / COMMAND_FULL_SCALE).clamp(-1.0, 1.0) * 0.5 + 0.5;
    // `half` is in [0, 1]: the product is in [0, max] and the cast cannot saturate.
    (half * f32::from(max)) as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    /// TIM3's full duty at 20 kHz from the 170 MHz timer clock (ARR + 1 = 8,500).
    const MAX: u16 = 8_500;

    #[test]
    fn zero_command_is_the_neutral_duty_and_full_scale_the_ends() {
        assert_eq!(duty(0.0, MAX), neutral_duty(MAX));
        assert_eq!(duty(-0.0, MAX), 4_250);
        assert_eq!(duty(COMMAND_FULL_SCALE, MAX), MAX);
        assert_eq!(duty(-COMMAND_FULL_SCALE, MAX), 0);
        assert_eq!(duty(10.0 * COMMAND_FULL_SCALE, MAX), MAX, "clamped");
        assert_eq!(duty(-1e30, MAX), 0, "clamped");
        for q in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(duty(q, MAX), neutral_duty(MAX), "{q}");
        }
    }

    #[test]
    fn duty_is_monotone_and_antisymmetric_about_neutral() {
        let mut last = 0;
        for k in -1_000..=1_000 {
            let q = k as f32 * COMMAND_FULL_SCALE / 1_000.0;
            let d = duty(q, MAX);
            assert!(d >= last, "q = {q}");
            last = d;
            let mirrored = i32::from(MAX) - i32::from(duty(-q, MAX));
            assert!((i32::from(d) - mirrored).abs() <= 1, "q = {q}");
        }
    }

    #[test]
    fn encoder_counts_give_position_and_speed_across_the_counter_wrap() {
        assert_eq!(encoder_state(0, None), [0.0, 0.0]);
        // 4,096 counts = one unit of x1; 4 counts in 1 ms = 4 / 4,096 / 1e-3 per second.
        let [x1, x2] = encoder_state(4_096 + 4, Some(4_096));
        assert_eq!(x1, (4_096.0 + 4.0) / 4_096.0);
        assert!((x2 - 4.0 / 4_096.0 / 1e-3).abs() < 1e-4, "{x2}");
        // Backwards through zero: the count wraps to 2^32 - 2, position -2 counts, speed < 0.
        let [x1, x2] = encoder_state(u32::MAX - 1, Some(3));
        assert_eq!(x1, -2.0 / 4_096.0);
        assert!((x2 + 5.0 / 4_096.0 / 1e-3).abs() < 1e-4, "{x2}");
    }
}
