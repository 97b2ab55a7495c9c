//! Why the board last reset and how often it has booted, for the heartbeat.
//!
//! **Reset cause** — `RCC_CSR[31:25]` (RM0440 §7.4.29): `LPWRRSTF`, `WWDGRSTF`, `IWDGRSTF`,
//! `SFTRSTF`, `BORRSTF`, `PINRSTF`, `OBLRSTF`. The flags accumulate until software sets
//! `RMVF`; the firmware reads them once at boot and then clears them, so each boot reports the
//! resets since the previous boot. An internal reset also drives the NRST pin, so `PINRSTF` is
//! set with every other cause; a power-on sets `BORRSTF` (the BOR covers POR/PDR on the G4).
//!
//! **Boot count** — kept in the backup register `TAMP_BKP0R` (RM0440 §38): the upper 16 bits
//! a marker, the lower 16 the count. The backup domain keeps its registers through every
//! system reset (pin, watchdog, software, brown-out while VBAT stays up) and loses them when
//! both VDD and VBAT go away: a NUCLEO-64 board as shipped ties VBAT to the MCU's 3.3 V with a
//! solder bridge, so a power cycle restarts the count at 1.
//!
//! **In the heartbeat** — the node's 16-bit boot-counter field (`agent_node::wire::Heartbeat`,
//! bytes 2..3) carries [`heartbeat_word`]: byte 2 the boot count modulo 256, byte 3 the reset
//! flags of this boot (`RCC_CSR[31:25]`, bit 0 `OBLRSTF` … bit 6 `LPWRRSTF`).

/// `RCC_CSR` reset flags, shifted down: bit 0 `OBLRSTF` … bit 6 `LPWRRSTF`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ResetFlags(u8);

impl ResetFlags {
    /// Option-byte loader reset.
    pub const OPTION_BYTES: u8 = 1 << 0;
    /// The NRST pin (also set by every internal reset).
    pub const PIN: u8 = 1 << 1;
    /// Brown-out, power-on or power-down reset.
    pub const BROWN_OUT: u8 = 1 << 2;
    /// Software reset (`SYSRESETREQ`).
    pub const SOFTWARE: u8 = 1 << 3;
    /// Independent watchdog.
    pub const IWDG: u8 = 1 << 4;
    /// Window watchdog.
    pub const WWDG: u8 = 1 << 5;
    /// Low-power reset (entering Stop/Standby when the option bytes forbid it).
    pub const LOW_POWER: u8 = 1 << 6;

    /// The flags of an `RCC_CSR` value.
    pub const fn from_csr(csr: u32) -> Self {
        Self(((csr >> 25) & 0x7F) as u8)
    }

    /// The seven flag bits.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// The flag(s) `mask` are set.
    pub const fn has(self, mask: u8) -> bool {
        self.0 & mask != 0
    }

    /// The most specific cause, for the log: a watchdog or software reset before a brown-out,
    /// the pin only when nothing else is set.
    pub const fn cause(self) -> ResetCause {
        if self.has(Self::IWDG) {
            ResetCause::IndependentWatchdog
        } else if self.has(Self::WWDG) {
            ResetCause::WindowWatchdog
        } else if self.has(Self::SOFTWARE) {
            ResetCause::Software
        } else if self.has(Self::LOW_POWER) {
            ResetCause::LowPower
        } else if self.has(Self::BROWN_OUT) {
            ResetCause::PowerOn
        } else if self.has(Self::OPTION_BYTES) {
            ResetCause::OptionBytes
        } else if self.has(Self::PIN) {
            ResetCause::Pin
        } else {
            ResetCause::Unknown
        }
    }
}

/// The cause named in the boot log line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum ResetCause {
    /// The IWDG expired: a control task that was not released or overran.
    IndependentWatchdog,
    /// The WWDG expired (not used by this firmware).
    WindowWatchdog,
    /// `SYSRESETREQ` (e.g. the debugger's reset).
    Software,
    /// A low-power mode the option bytes forbid.
    LowPower,
    /// Power-on or brown-out.
    PowerOn,
    /// Option bytes reloaded.
    OptionBytes,
    /// The reset button / NRST pin.
    Pin,
    /// No flag set (flags cleared without a reset).
    Unknown,
}

/// Marker in the upper half of `TAMP_BKP0R`: the lower half is a boot count.
pub const BOOT_MARKER: u32 = 0xB007_0000;

/// The new value of `TAMP_BKP0R` and this boot's count (1 for the first), from the value it
/// held at reset: a register without the marker (backup domain reset: power cycle) starts at 1;
/// the count saturates at `u16::MAX`.
pub fn next_boot(stored: u32) -> (u32, u16) {
    let count = if stored & 0xFFFF_0000 == BOOT_MARKER {
        (stored as u16).saturating_add(1)
    } else {
        1
    };
    (BOOT_MARKER | u32::from(count), count)
}

/// The heartbeat's boot-counter field: the boot count modulo 256 in the low byte (byte 2 on
/// the wire), the reset flags of this boot in the high byte (byte 3).
pub const fn heartbeat_word(boot_count: u16, flags: ResetFlags) -> u16 {
    (boot_count & 0xFF) | ((flags.bits() as u16) << 8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csr_flags_map_to_their_bits_and_the_most_specific_cause() {
        // A watchdog reset: IWDGRSTF (29) and PINRSTF (26).
        let f = ResetFlags::from_csr((1 << 29) | (1 << 26) | 0x0000_0C01);
        assert_eq!(f.bits(), ResetFlags::IWDG | ResetFlags::PIN);
        assert_eq!(f.cause(), ResetCause::IndependentWatchdog);
        // Power-on: BORRSTF (27) and PINRSTF.
        let f = ResetFlags::from_csr((1 << 27) | (1 << 26));
        assert_eq!(f.cause(), ResetCause::PowerOn);
        assert_eq!(ResetFlags::from_csr(1 << 26).cause(), ResetCause::Pin);
        assert_eq!(ResetFlags::from_csr(1 << 28).cause(), ResetCause::Software);
        assert_eq!(ResetFlags::from_csr(1 << 31).cause(), ResetCause::LowPower);
        assert_eq!(
            ResetFlags::from_csr(1 << 30).cause(),
            ResetCause::WindowWatchdog
        );
        assert_eq!(
            ResetFlags::from_csr(1 << 25).cause(),
            ResetCause::OptionBytes
        );
        assert_eq!(
            ResetFlags::from_csr(0x01FF_FFFF).cause(),
            ResetCause::Unknown
        );
        assert_eq!(ResetFlags::from_csr(u32::MAX).bits(), 0x7F);
    }

    #[test]
    fn the_boot_count_starts_at_one_after_a_power_cycle_and_counts_resets() {
        let (reg, n) = next_boot(0);
        assert_eq!((reg, n), (0xB007_0001, 1));
        let (reg, n) = next_boot(reg);
        assert_eq!((reg, n), (0xB007_0002, 2));
        assert_eq!(next_boot(0x1234_5678), (0xB007_0001, 1), "garbage: restart");
        assert_eq!(next_boot(0xB007_FFFF), (0xB007_FFFF, u16::MAX), "saturates");
    }

    #[test]
    fn the_heartbeat_word_has_the_count_low_and_the_flags_high() {
        let f = ResetFlags::from_csr((1 << 29) | (1 << 26));
        let w = heartbeat_word(258, f);
        assert_eq!(w.to_le_bytes(), [2, 0x12]);
        assert_eq!(heartbeat_word(7, ResetFlags::default()), 7);
    }
}
