//! The independent watchdog's register values for a timeout (RM0440 §42 "IWDG").
//!
//! The IWDG counts down from its reload value `RL` (`IWDG_RLR`, 12 bits) at the LSI clock
//! divided by `4 · 2^PR` (`IWDG_PR`, `PR` = 0..=6: ÷4 … ÷256) and resets the device when the
//! count reaches zero, so the timeout is `(RL + 1) · 4 · 2^PR / f_LSI`. [`IwdgSetting::for_timeout`]
//! takes the smallest prescaler that reaches the timeout (the finest resolution) and the
//! largest reload that does not exceed it: the board is never reset *later* than asked, at
//! the nominal LSI frequency (32 kHz; RM0440 gives the LSI's spread in the datasheet, about
//! ±8 %, so the actual timeout varies by that much).

/// The nominal LSI frequency [Hz].
pub const LSI_HZ: u32 = 32_000;
/// `IWDG_RLR` is 12 bits.
pub const RL_MAX: u16 = 0x0FFF;
/// `IWDG_PR` values 0..=6 (÷4 … ÷256); 7 is ÷256 as well.
pub const PR_MAX: u8 = 6;

/// The values written to `IWDG_PR` and `IWDG_RLR`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IwdgSetting {
    /// `IWDG_PR.PR`: the LSI is divided by `4 << pr`.
    pub pr: u8,
    /// `IWDG_RLR.RL`: the count reloaded by every refresh.
    pub rl: u16,
}

impl IwdgSetting {
    /// The setting whose timeout is closest to `timeout_us` without exceeding it; `None`
    /// when it is shorter than one tick of the fastest prescaler or longer than the slowest
    /// can count.
    pub fn for_timeout(timeout_us: u32, lsi_hz: u32) -> Option<Self> {
        (0..=PR_MAX).find_map(|pr| {
            let divider = 4u64 << pr;
            // Ticks of the prescaled clock in the timeout, rounded down.
            let ticks = u64::from(timeout_us) * u64::from(lsi_hz) / (divider * 1_000_000);
            let rl = ticks.checked_sub(1)?;
            (rl <= u64::from(RL_MAX)).then(|| Self {
                pr,
                rl: u16::try_from(rl).unwrap_or(RL_MAX),
            })
        })
    }

    /// The timeout of this setting at `lsi_hz` [µs], rounded down.
    pub fn timeout_us(&self, lsi_hz: u32) -> u64 {
        (u64::from(self.rl) + 1) * (4u64 << self.pr) * 1_000_000 / u64::from(lsi_hz.max(1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn five_milliseconds_is_forty_ticks_of_the_divide_by_four_clock() {
        // 32 kHz / 4 = 8 kHz: 125 µs per tick, 40 ticks = 5 ms, RL = 39.
        let s = IwdgSetting::for_timeout(5_000, LSI_HZ).expect("fits");
        assert_eq!(s, IwdgSetting { pr: 0, rl: 39 });
        assert_eq!(s.timeout_us(LSI_HZ), 5_000);
    }

    #[test]
    fn the_range_ends_of_rm0440s_timeout_table() {
        // ÷4: 0.125 ms … 512 ms; ÷256: 8 ms … 32,768 ms.
        assert_eq!(
            IwdgSetting::for_timeout(125, LSI_HZ),
            Some(IwdgSetting { pr: 0, rl: 0 })
        );
        assert_eq!(IwdgSetting::for_timeout(124, LSI_HZ), None);
        assert_eq!(
            IwdgSetting::for_timeout(512_000, LSI_HZ),
            Some(IwdgSetting { pr: 0, rl: RL_MAX })
        );
        assert_eq!(
            IwdgSetting::for_timeout(512_125, LSI_HZ),
            Some(IwdgSetting { pr: 1, rl: 2_047 })
        );
        assert_eq!(
            IwdgSetting::for_timeout(32_768_000, LSI_HZ),
            Some(IwdgSetting { pr: 6, rl: RL_MAX })
        );
        assert_eq!(IwdgSetting::for_timeout(32_768_000 + 8_000, LSI_HZ), None);
    }

    /// Every timeout from 125 µs to 32.768 s in steps of 997 µs: never later than asked, and
    /// less than one prescaled tick earlier.
    #[test]
    fn the_timeout_is_never_longer_than_asked_and_within_one_tick() {
        let mut t = 125;
        while t <= 32_768_000 {
            let s = IwdgSetting::for_timeout(t, LSI_HZ).expect("in range");
            assert!(s.pr <= PR_MAX && s.rl <= RL_MAX, "{t}: {s:?}");
            let got = s.timeout_us(LSI_HZ);
            let tick = (4u64 << s.pr) * 1_000_000 / u64::from(LSI_HZ);
            assert!(
                got <= u64::from(t) && u64::from(t) - got < tick,
                "{t}: {got}"
            );
            t += 997;
        }
    }
}
