//! The stored configuration: one flash page that holds the CANopen device's stored object
//! dictionary (`agent_node::canopen::Device::save`, CiA 301 `0x1010` "save"), and the boot
//! decision that reads it.
//!
//! ## Page layout (little endian)
//!
//! | bytes | field |
//! |---|---|
//! | 0–3 | [`MAGIC`] `AGCF` |
//! | 4–5 | [`VERSION`] of this layout |
//! | 6–7 | length `L` of the stored object dictionary |
//! | 8–11 | CRC-32 (IEEE 802.3) of bytes 4–7 and of the `L` bytes that follow |
//! | 12… | the stored object dictionary, then `0xFF` up to a multiple of 8 bytes |
//!
//! The flash programs double words (8 bytes, RM0440 §5.3.7), so the page is written as
//! [`double_words`] after one page erase. An erased page reads all `0xFF`.
//!
//! ## Boot decision ([`boot_config`])
//!
//! | page | node-ID (agent) | stored dictionary | EMCY `0x6300` (byte 2 of the EMCY: [`Rejection`]) |
//! |---|---|---|---|
//! | valid, node-ID in the compiled plan, or with a stored graph row | the stored `node.node_id` | loaded | none |
//! | valid, node-ID outside the compiled plan and no stored row | the default | not loaded | [`Rejection::NodeIdOutsidePlan`] |
//! | erased (never stored, or `0x1011` "load") | the default | none | [`Rejection::Erased`] |
//! | wrong magic, length or CRC | the default | not loaded | [`Rejection::Corrupt`] |
//! | another layout version | the default | not loaded | [`Rejection::Version`] |
//!
//! The firmware adds [`Rejection::Refused`] when the device refuses a valid page's dictionary
//! (`Device::load`: the node keeps the node-ID of the page and the compiled defaults). Nothing
//! here panics on any page content (the tests feed every corruption of a stored page).

use agent_node::canopen::od::{Setting, PARAM_BASE, SETTING_BASE};
use controller_core::Param;

/// First bytes of a stored page: `AGCF` (agent configuration).
pub const MAGIC: [u8; 4] = *b"AGCF";
/// Layout version; a page of another version is refused (the defaults run). Version 2: the
/// stored dictionary may hold the graph row and the identifier plan (a version-1 page was
/// written by a firmware that read its row from the compiled plan alone).
pub const VERSION: u16 = 2;
/// Bytes before the stored object dictionary.
pub const HEADER_BYTES: usize = 12;
/// Bytes of the flash page (a dual-bank STM32G474 page).
pub const PAGE_BYTES: usize = 2048;
/// Most bytes of a stored object dictionary the page holds.
pub const MAX_STORED: usize = PAGE_BYTES - HEADER_BYTES;

/// Why the stored page was not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum PageError {
    /// All `0xFF`: nothing stored.
    Erased,
    /// Not [`MAGIC`], a length beyond the page, or a CRC that does not match.
    Corrupt,
    /// A valid page of another layout [`VERSION`].
    Version(u16),
}

/// Why the boot used the compiled defaults; the EMCY `0x6300` count bytes carry its code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Rejection {
    /// 1: nothing stored (a new board, or after `0x1011` "load").
    Erased,
    /// 2: magic, length or CRC wrong.
    Corrupt,
    /// 3: another layout version.
    Version,
    /// 4: the stored node-ID is not an agent of the compiled plan (or is missing).
    NodeIdOutsidePlan,
    /// 5: the device refused the stored dictionary (`Device::load`).
    Refused,
}

impl Rejection {
    /// The code in the EMCY's count bytes (`agent_node::canopen::Fault::info`).
    pub const fn code(self) -> u16 {
        match self {
            Self::Erased => 1,
            Self::Corrupt => 2,
            Self::Version => 3,
            Self::NodeIdOutsidePlan => 4,
            Self::Refused => 5,
        }
    }
}

impl From<PageError> for Rejection {
    fn from(e: PageError) -> Self {
        match e {
            PageError::Erased => Self::Erased,
            PageError::Corrupt => Self::Corrupt,
            PageError::Version(_) => Self::Version,
        }
    }
}

/// CRC-32 (IEEE 802.3, reflected polynomial `0xEDB8_8320`, initial and final XOR
/// `0xFFFF_FFFF`) continued over `bytes` from the running value `crc` (start with
/// `0xFFFF_FFFF`, finish with `!crc`).
fn crc32_update(mut crc: u32, bytes: &[u8]) -> u32 {
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            let mask = (crc & 1).wrapping_neg();
            crc = (crc >> 1) ^ (0xEDB8_8320 & mask);
        }
    }
    crc
}

/// The page's CRC: over the version and length bytes and the stored dictionary.
fn page_crc(version_length: &[u8], stored: &[u8]) -> u32 {
    !crc32_update(crc32_update(0xFFFF_FFFF, version_length), stored)
}

/// The header of a page holding `stored`; `None` when it is longer than [`MAX_STORED`].
pub fn header(stored: &[u8]) -> Option<[u8; HEADER_BYTES]> {
    if stored.len() > MAX_STORED {
        return None;
    }
    let len = u16::try_from(stored.len()).ok()?;
    let mut h = [0u8; HEADER_BYTES];
    let v = VERSION.to_le_bytes();
    let l = len.to_le_bytes();
    let vl = [v[0], v[1], l[0], l[1]];
    let c = page_crc(&vl, stored).to_le_bytes();
    let fields = MAGIC.iter().chain(&vl).chain(&c);
    for (d, s) in h.iter_mut().zip(fields) {
        *d = *s;
    }
    Some(h)
}

/// The double words to program, in order from the page's start: header, `stored`, `0xFF`
/// padding; `None` when `stored` does not fit the page.
pub fn double_words(stored: &[u8]) -> Option<impl Iterator<Item = [u8; 8]> + '_> {
    let h = header(stored)?;
    let total = HEADER_BYTES + stored.len();
    let words = total.div_ceil(8);
    let byte = move |k: usize| -> u8 {
        match k.checked_sub(HEADER_BYTES) {
            None => h.get(k).copied().unwrap_or(0xFF),
            Some(j) => stored.get(j).copied().unwrap_or(0xFF),
        }
    };
    Some((0..words).map(move |w| core::array::from_fn(|b| byte(8 * w + b))))
}

/// The stored object dictionary of a page (the flash page's bytes, or a prefix holding it).
pub fn decode(page: &[u8]) -> Result<&[u8], PageError> {
    let head = page.get(..HEADER_BYTES).ok_or(PageError::Corrupt)?;
    if head.iter().all(|&b| b == 0xFF) {
        return Err(PageError::Erased);
    }
    let field = |k: usize| head.get(k).copied().unwrap_or(0);
    if head.get(..4) != Some(&MAGIC[..]) {
        return Err(PageError::Corrupt);
    }
    let version = u16::from_le_bytes([field(4), field(5)]);
    let len = usize::from(u16::from_le_bytes([field(6), field(7)]));
    let crc = u32::from_le_bytes([field(8), field(9), field(10), field(11)]);
    let stored = page
        .get(HEADER_BYTES..HEADER_BYTES + len)
        .filter(|_| len <= MAX_STORED)
        .ok_or(PageError::Corrupt)?;
    if page_crc(head.get(4..8).unwrap_or(&[]), stored) != crc {
        return Err(PageError::Corrupt);
    }
    if version != VERSION {
        return Err(PageError::Version(version));
    }
    Ok(stored)
}

/// The flash page behind the stored configuration: read, erase, program double words.
/// The board implements it on the STM32G474's flash (`src/flash.rs`); the tests on memory.
pub trait ParamFlash {
    /// Why an erase or a program failed.
    type Error;
    /// The page's bytes as they are now.
    fn page(&self) -> &[u8];
    /// Erase the page (all `0xFF`).
    fn erase(&mut self) -> Result<(), Self::Error>;
    /// Program the double word at byte `offset` (a multiple of 8) of the erased page.
    fn program(&mut self, offset: usize, word: [u8; 8]) -> Result<(), Self::Error>;
}

/// Why storing failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum StoreError<E> {
    /// The dictionary is longer than [`MAX_STORED`].
    TooLong,
    /// The flash refused the erase or a program.
    Flash(E),
    /// The page read back is not what was written.
    Verify,
}

/// Store `stored` (`Device::save`'s bytes) in the page: erase, program, read back.
pub fn store<F: ParamFlash>(flash: &mut F, stored: &[u8]) -> Result<(), StoreError<F::Error>> {
    let words = double_words(stored).ok_or(StoreError::TooLong)?;
    flash.erase().map_err(StoreError::Flash)?;
    for (k, w) in words.enumerate() {
        flash.program(8 * k, w).map_err(StoreError::Flash)?;
    }
    match decode(flash.page()) {
        Ok(back) if back == stored => Ok(()),
        _ => Err(StoreError::Verify),
    }
}

/// The CANopen object of `node.node_id` (`0x2100 + k`, sub-index 0).
pub fn node_id_index() -> u16 {
    let k = Setting::ALL
        .iter()
        .position(|s| *s == Setting::NodeId)
        .unwrap_or(0);
    SETTING_BASE + k as u16
}

/// The CANopen object of the graph row `graph.neighbours` (`0x2000 + k`).
pub fn row_index() -> u16 {
    let k = Param::ALL
        .iter()
        .position(|p| *p == Param::Neighbours)
        .unwrap_or(0);
    PARAM_BASE + k as u16
}

/// The bytes of record `index`/`sub` of a stored dictionary (`Device::save`'s records: index
/// `u16` LE, sub-index, length, bytes, after a 4-byte tag); `None` when absent or malformed.
fn stored_record(stored: &[u8], index: u16, sub: u8) -> Option<&[u8]> {
    let index = index.to_le_bytes();
    let mut rest = stored.get(4..)?;
    while let [i0, i1, s, len, tail @ ..] = rest {
        let data = tail.get(..usize::from(*len))?;
        if [*i0, *i1] == index && *s == sub {
            return Some(data);
        }
        rest = tail.get(data.len()..)?;
    }
    None
}

/// The node-ID a stored dictionary holds: its `node.node_id` record; `None` when absent or
/// malformed.
pub fn stored_node_id(stored: &[u8]) -> Option<u8> {
    match stored_record(stored, node_id_index(), 0)? {
        [id] => Some(*id),
        _ => None,
    }
}

/// What the board boots as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BootConfig<'a> {
    /// The agent number and CANopen node-ID.
    pub agent: u8,
    /// The stored object dictionary to load (`Device::load`), if the page is used.
    pub stored: Option<&'a [u8]>,
    /// Why the compiled defaults run, reported by EMCY `0x6300`.
    pub rejected: Option<Rejection>,
}

/// The boot decision (module docs' table): the stored page `page`, the agents of the compiled
/// plan (`in_plan`), the default node-ID `default_agent`.
pub fn boot_config(page: &[u8], in_plan: impl Fn(u8) -> bool, default_agent: u8) -> BootConfig<'_> {
    let defaults = |r: Rejection| BootConfig {
        agent: default_agent,
        stored: None,
        rejected: Some(r),
    };
    let stored = match decode(page) {
        Ok(s) => s,
        Err(e) => return defaults(e.into()),
    };
    let has_row = stored_record(stored, row_index(), 0).is_some();
    match stored_node_id(stored) {
        Some(id) if in_plan(id) || (has_row && id > 0) => BootConfig {
            agent: id,
            stored: Some(stored),
            rejected: None,
        },
        _ => defaults(Rejection::NodeIdOutsidePlan),
    }
}

/// Most bytes of a stored object dictionary the firmware keeps for a store (`board::tests`
/// saves the board's dictionary into this much and prints its length).
pub const STORE_CAPACITY: usize = 768;
const _: () = assert!(
    STORE_CAPACITY <= MAX_STORED,
    "a kept dictionary fits the page"
);

/// A stored object dictionary on its way to the flash.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Stored {
    bytes: [u8; STORE_CAPACITY],
    len: usize,
}

impl Stored {
    /// Its bytes.
    pub fn as_slice(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&[])
    }
}

/// What the idle task does next with the flash ([`Jobs::take`]). The stored dictionary
/// travels by value: the idle task programs it from its own stack while the control task may
/// already queue the next one.
#[derive(Debug, Clone, PartialEq, Eq)]
#[allow(clippy::large_enum_variant)]
pub enum Job {
    /// `0x1010` "save": [`store`] this.
    Store(Stored),
    /// `0x1011` "load": erase the page (the defaults at the next boot).
    Erase,
    /// NMT reset node (or a node-ID adopted without one): restart the board, after the
    /// flash work requested before it.
    Reset,
}

/// The control task's requests for the idle task, which waits for the flash while the
/// control task keeps running: the latest of store and restore wins; a reset waits until
/// both are done.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Jobs {
    stored: Stored,
    flash: Option<bool>,
    reset: bool,
}

impl Default for Jobs {
    fn default() -> Self {
        Self::new()
    }
}

impl Jobs {
    /// Nothing requested.
    pub const fn new() -> Self {
        Self {
            stored: Stored {
                bytes: [0; STORE_CAPACITY],
                len: 0,
            },
            flash: None,
            reset: false,
        }
    }

    /// A store of what `save` writes (`Device::save`); `false` (nothing requested) when it
    /// does not fit.
    pub fn store_with(&mut self, save: impl FnOnce(&mut [u8]) -> Option<usize>) -> bool {
        match save(&mut self.stored.bytes) {
            Some(len) if len <= STORE_CAPACITY => {
                self.stored.len = len;
                self.flash = Some(true);
                true
            }
            _ => false,
        }
    }

    /// Erase the page.
    pub fn erase(&mut self) {
        self.flash = Some(false);
    }

    /// Restart the board once the flash work is done.
    pub fn reset(&mut self) {
        self.reset = true;
    }

    /// The next job, if any.
    pub fn take(&mut self) -> Option<Job> {
        match self.flash.take() {
            Some(true) => Some(Job::Store(self.stored.clone())),
            Some(false) => Some(Job::Erase),
            None => core::mem::take(&mut self.reset).then_some(Job::Reset),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The page on memory, with flash semantics: erase sets `0xFF`, a program may only clear
    /// bits of an erased double word.
    struct MemFlash {
        page: Vec<u8>,
        fail_program_at: Option<usize>,
    }

    impl MemFlash {
        fn erased() -> Self {
            Self {
                page: vec![0xFF; PAGE_BYTES],
                fail_program_at: None,
            }
        }
    }

    impl ParamFlash for MemFlash {
        type Error = &'static str;
        fn page(&self) -> &[u8] {
            &self.page
        }
        fn erase(&mut self) -> Result<(), Self::Error> {
            self.page.fill(0xFF);
            Ok(())
        }
        fn program(&mut self, offset: usize, word: [u8; 8]) -> Result<(), Self::Error> {
            if self.fail_program_at == Some(offset) {
                return Err("programming error");
            }
            let dst = self.page.get_mut(offset..offset + 8).ok_or("outside")?;
            if !offset.is_multiple_of(8) || dst.iter().any(|&b| b != 0xFF) {
                return Err("not an erased, aligned double word");
            }
            dst.copy_from_slice(&word);
            Ok(())
        }
    }

    /// A stored dictionary as `Device::save` writes it, with `node.node_id` = `id`.
    fn dictionary(id: u8) -> Vec<u8> {
        let i = node_id_index().to_le_bytes();
        let mut v = b"CO1\0".to_vec();
        v.extend_from_slice(&[0x00, 0x20, 0, 4, 0, 0, 0x80, 0x3F]); // h = 1.0 (REAL32)
        v.extend_from_slice(&[i[0], i[1], 0, 1, id]);
        v
    }

    fn in_plan(id: u8) -> bool {
        (1..=4).contains(&id)
    }

    /// The boot on the compiled defaults as agent 4, for `r`.
    fn defaults(r: Rejection) -> BootConfig<'static> {
        BootConfig {
            agent: 4,
            stored: None,
            rejected: Some(r),
        }
    }

    #[test]
    fn the_latest_flash_request_wins_and_a_reset_waits_for_it() {
        let mut j = Jobs::new();
        assert_eq!(j.take(), None);
        j.reset();
        assert!(j.store_with(|b| {
            b[..3].copy_from_slice(b"abc");
            Some(3)
        }));
        match j.take() {
            Some(Job::Store(s)) => assert_eq!(s.as_slice(), b"abc"),
            other => panic!("{other:?}"),
        }
        assert_eq!(j.take(), Some(Job::Reset));
        assert_eq!(j.take(), None);
        // Store then restore: the page is erased; restore then store: stored.
        assert!(j.store_with(|_| Some(0)));
        j.erase();
        assert_eq!(j.take(), Some(Job::Erase));
        j.erase();
        assert!(j.store_with(|_| Some(1)));
        assert!(matches!(j.take(), Some(Job::Store(_))));
        // A dictionary that does not fit requests nothing.
        assert!(!j.store_with(|_| None));
        assert!(!j.store_with(|_| Some(STORE_CAPACITY + 1)));
        assert_eq!(j.take(), None);
    }

    #[test]
    fn crc32_is_the_ieee_check_value() {
        // The standard check: CRC-32 of "123456789" is 0xCBF43926.
        assert_eq!(!crc32_update(0xFFFF_FFFF, b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn node_id_is_the_first_setting() {
        assert_eq!(node_id_index(), 0x2100);
    }

    #[test]
    fn a_stored_page_reads_back_and_boots_as_its_node_id() {
        let mut f = MemFlash::erased();
        let d = dictionary(2);
        store(&mut f, &d).unwrap();
        assert_eq!(decode(f.page()), Ok(&d[..]));
        assert_eq!(
            boot_config(f.page(), in_plan, 4),
            BootConfig {
                agent: 2,
                stored: Some(&d[..]),
                rejected: None
            }
        );
        // Programmed length: header + dictionary rounded up to double words, the rest erased.
        let used = (HEADER_BYTES + d.len()).div_ceil(8) * 8;
        assert!(f.page()[used..].iter().all(|&b| b == 0xFF));
        // Storing again (another node-ID) replaces it.
        store(&mut f, &dictionary(3)).unwrap();
        assert_eq!(boot_config(f.page(), in_plan, 4).agent, 3);
    }

    #[test]
    fn an_erased_page_boots_the_default_node_id_and_says_so() {
        let f = MemFlash::erased();
        assert_eq!(
            boot_config(f.page(), in_plan, 4),
            defaults(Rejection::Erased)
        );
        assert_eq!(Rejection::Erased.code(), 1);
    }

    #[test]
    fn every_single_bit_flip_of_a_stored_page_is_refused() {
        let mut f = MemFlash::erased();
        let d = dictionary(1);
        store(&mut f, &d).unwrap();
        let used = HEADER_BYTES + d.len();
        for k in 0..used {
            for bit in 0..8 {
                let mut p = f.page.clone();
                p[k] ^= 1 << bit;
                let b = boot_config(&p, in_plan, 4);
                assert_eq!(b.agent, 4, "byte {k} bit {bit}");
                assert_eq!(b.stored, None, "byte {k} bit {bit}");
                assert!(
                    matches!(
                        b.rejected,
                        Some(Rejection::Corrupt | Rejection::Erased | Rejection::Version)
                    ),
                    "byte {k} bit {bit}: {:?}",
                    b.rejected
                );
            }
        }
    }

    #[test]
    fn a_torn_write_or_an_overlong_length_is_corrupt_never_a_panic() {
        let mut f = MemFlash::erased();
        let d = dictionary(1);
        store(&mut f, &d).unwrap();
        // Power lost after the first double word: the header is there, the rest erased.
        let mut torn = vec![0xFF; PAGE_BYTES];
        torn[..8].copy_from_slice(&f.page[..8]);
        assert_eq!(decode(&torn), Err(PageError::Corrupt));
        // A length beyond the page (0xFFFF) and pages shorter than the header.
        let mut long = f.page.clone();
        long[6] = 0xFF;
        long[7] = 0xFF;
        assert_eq!(decode(&long), Err(PageError::Corrupt));
        for n in 0..HEADER_BYTES {
            assert_eq!(decode(&f.page[..n]), Err(PageError::Corrupt));
        }
        assert_eq!(decode(&[]), Err(PageError::Corrupt));
    }

    #[test]
    fn another_layout_version_is_refused_by_name() {
        let d = dictionary(1);
        let mut p = vec![0xFF; PAGE_BYTES];
        // A page of the version-1 layout (before the stored graph row), with its own valid
        // CRC: the compiled defaults and EMCY 0x6300 with reason 3.
        let vl = [1, 0, d.len() as u8, 0];
        let crc = page_crc(&vl, &d).to_le_bytes();
        p[..4].copy_from_slice(&MAGIC);
        p[4..8].copy_from_slice(&vl);
        p[8..12].copy_from_slice(&crc);
        p[12..12 + d.len()].copy_from_slice(&d);
        assert_eq!(decode(&p), Err(PageError::Version(1)));
        assert_eq!(
            boot_config(&p, in_plan, 4).rejected,
            Some(Rejection::Version)
        );
    }

    #[test]
    fn a_node_id_outside_the_plan_or_missing_boots_the_default() {
        for id in [0, 5, 127, 255] {
            let mut f = MemFlash::erased();
            store(&mut f, &dictionary(id)).unwrap();
            assert_eq!(
                boot_config(f.page(), in_plan, 4),
                defaults(Rejection::NodeIdOutsidePlan),
                "node-ID {id}"
            );
        }
        // A dictionary without the node-ID record, and one with a two-byte node-ID.
        let mut f = MemFlash::erased();
        store(&mut f, b"CO1\0").unwrap();
        assert_eq!(
            boot_config(f.page(), in_plan, 4).rejected,
            Some(Rejection::NodeIdOutsidePlan)
        );
        let i = node_id_index().to_le_bytes();
        assert_eq!(
            stored_node_id(&[b'C', b'O', b'1', 0, i[0], i[1], 0, 2, 3, 0]),
            None
        );
        // A record whose length runs past the end.
        assert_eq!(
            stored_node_id(&[b'C', b'O', b'1', 0, i[0], i[1], 0, 9, 3]),
            None
        );
    }

    #[test]
    fn a_dictionary_too_long_for_the_page_is_not_stored_and_the_page_is_kept() {
        let mut f = MemFlash::erased();
        store(&mut f, &dictionary(2)).unwrap();
        let before = f.page.clone();
        let long = vec![0u8; MAX_STORED + 1];
        assert_eq!(store(&mut f, &long), Err(StoreError::TooLong));
        assert_eq!(f.page, before);
        // The longest that fits fills the page exactly.
        let full = vec![0u8; MAX_STORED];
        assert_eq!(double_words(&full).unwrap().count(), PAGE_BYTES / 8);
    }

    #[test]
    fn a_failed_program_is_reported_and_the_torn_page_boots_the_defaults() {
        let mut f = MemFlash::erased();
        f.fail_program_at = Some(8);
        assert_eq!(
            store(&mut f, &dictionary(2)),
            Err(StoreError::Flash("programming error"))
        );
        assert_eq!(boot_config(f.page(), in_plan, 4).agent, 4);
    }
}
