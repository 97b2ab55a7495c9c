//! The stored configuration's flash page on the STM32G474RE ([`ParamPage`], the board's
//! [`ParamFlash`]): the last page of bank 2, `0x0807_F800`, 2 KiB, in the dual-bank layout
//! (`FLASH_OPTR.DBANK` = 1, the factory default; RM0440 §5.3). `memory.x` keeps the code out
//! of the last 4 KiB. The code runs from bank 1, so erasing and programming bank 2 does not
//! stall instruction fetches (read-while-write, RM0440 §5.3.6): the control task keeps
//! preempting the idle task that waits for the flash.
//!
//! The page erase (`PER`, `BKER`, `PNB`, `STRT`) and the double-word programming (`PG`) as
//! RM0440 §5.3.7–5.3.8 describe them; `unsafe` only where the peripheral access crate marks a
//! field unchecked (key, page number, status bits) and for the two 32-bit writes into flash
//! and the page's read-only view, each with its reason.

use nucleo_g474re::param_page::{ParamFlash, PAGE_BYTES};
use stm32g4xx_hal::stm32::FLASH;

/// Address of the page.
pub const PAGE_ADDRESS: usize = 0x0807_F800;
/// Its number within bank 2.
const BANK2_PAGE: u8 = 127;
/// `FLASH_KEYR` unlock sequence.
const KEY1: u32 = 0x4567_0123;
const KEY2: u32 = 0xCDEF_89AB;
/// `FLASH_SR` error flags (write 1 to clear): OPTVERR, RDERR, FASTERR, MISERR, PGSERR,
/// SIZERR, PGAERR, WRPERR, PROGERR, OPERR.
const SR_ERRORS: u32 = 0xC3FA;

/// Why the flash refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum FlashError {
    /// `FLASH_OPTR.DBANK` = 0 (single bank, 4 KiB pages): the page address would be wrong.
    SingleBank,
    /// The unlock sequence did not clear `FLASH_CR.LOCK`.
    Locked,
    /// An offset outside the page or not a multiple of 8.
    Offset,
    /// The operation ended with these `FLASH_SR` error flags.
    Status(u32),
}

/// The page and the flash controller.
pub struct ParamPage {
    flash: FLASH,
}

impl ParamPage {
    /// Own the flash controller (its wait states were set by the clock set-up before).
    pub fn new(flash: FLASH) -> Self {
        Self { flash }
    }

    fn wait(&self) {
        while self.flash.sr().read().bsy().bit_is_set() {}
    }

    fn unlock(&mut self) -> Result<(), FlashError> {
        if !self.flash.optr().read().dbank().bit_is_set() {
            return Err(FlashError::SingleBank);
        }
        self.wait();
        if self.flash.cr().read().lock().bit_is_set() {
            // SAFETY: the key register takes any 32-bit value; these two in this order are the
            // documented unlock sequence (a wrong one locks the controller until reset).
            self.flash.keyr().write(|w| unsafe { w.keyr().bits(KEY1) });
            self.flash.keyr().write(|w| unsafe { w.keyr().bits(KEY2) });
        }
        if self.flash.cr().read().lock().bit_is_set() {
            return Err(FlashError::Locked);
        }
        // SAFETY: writing ones clears the error flags; zeros leave every flag as it is.
        self.flash.sr().write(|w| unsafe { w.bits(SR_ERRORS) });
        Ok(())
    }

    /// Wait, clear the operation bits, lock, flush the data cache (it may hold the page's
    /// old contents); the error flags of the operation.
    fn finish(&mut self) -> Result<(), FlashError> {
        self.wait();
        let errors = self.flash.sr().read().bits() & SR_ERRORS;
        self.flash
            .cr()
            .modify(|_, w| w.per().clear_bit().pg().clear_bit().lock().set_bit());
        self.flash.acr().modify(|_, w| w.dcen().clear_bit());
        self.flash.acr().modify(|_, w| w.dcrst().set_bit());
        self.flash
            .acr()
            .modify(|_, w| w.dcrst().clear_bit().dcen().set_bit());
        match errors {
            0 => Ok(()),
            e => Err(FlashError::Status(e)),
        }
    }
}

impl ParamFlash for ParamPage {
    type Error = FlashError;

    fn page(&self) -> &[u8] {
        // SAFETY: 2 KiB of flash at a fixed address, inside the part and outside the image
        // (`memory.x`); always readable; changed only through `&mut self`, which this borrow
        // excludes.
        unsafe { core::slice::from_raw_parts(PAGE_ADDRESS as *const u8, PAGE_BYTES) }
    }

    fn erase(&mut self) -> Result<(), FlashError> {
        self.unlock()?;
        // SAFETY: PNB is 7 bits; 127 is the last page of a 128-page bank.
        self.flash
            .cr()
            .modify(|_, w| unsafe { w.per().set_bit().bker().bank2().pnb().bits(BANK2_PAGE) });
        self.flash.cr().modify(|_, w| w.strt().set_bit());
        self.finish()
    }

    fn program(&mut self, offset: usize, word: [u8; 8]) -> Result<(), FlashError> {
        if !offset.is_multiple_of(8) || offset + 8 > PAGE_BYTES {
            return Err(FlashError::Offset);
        }
        self.unlock()?;
        self.flash.cr().modify(|_, w| w.pg().set_bit());
        let at = (PAGE_ADDRESS + offset) as *mut u32;
        let [a0, a1, a2, a3, b0, b1, b2, b3] = word;
        // SAFETY: an aligned double word inside the page (checked above), `PG` set: the two
        // word writes are the programming sequence; nothing else aliases the page mutably.
        unsafe {
            core::ptr::write_volatile(at, u32::from_le_bytes([a0, a1, a2, a3]));
            core::ptr::write_volatile(at.add(1), u32::from_le_bytes([b0, b1, b2, b3]));
        }
        self.finish()
    }
}
