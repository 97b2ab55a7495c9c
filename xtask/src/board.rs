//! `board-size`: builds the board firmware `boards/nucleo-g474re` in release, as shipped and with
//! its `bench` feature (plant-bus frames instead of encoder and PWM), and holds both ELFs to a
//! part with 64 KiB of flash and 16 KiB of RAM.
//!
//! The figures are those of Berkeley `size`, read from the ELF's allocated sections: `text` =
//! code and read-only data (vector table, `.text`, `.rodata`), `data` = initialised RAM
//! (`.data`, whose initial image also lies in flash), `bss` = zeroed and uninitialised RAM
//! (`.bss`, `.uninit`: RTIC's resources, the RTT buffer). The gate: `text + data` ≤ 64 KiB
//! (everything flash holds), `data + bss` ≤ 16 KiB (what RAM holds before the stack). The
//! figures are also written to [`SIZE_JSON`] for `cargo xtask docs` (`board.KEY`; the bench
//! build's as `board.bench_KEY`).

use crate::task::{firmware_build, workspace_root, Options, Result};
use object::{elf::SHF_ALLOC, Object, ObjectSection, SectionFlags, SectionKind};

/// The board firmware's directory under the workspace root.
pub const BOARD_DIR: &str = "boards/nucleo-g474re";
/// Where `board-size` builds it, under the workspace root (see [`firmware_build`]); both
/// builds of [`BUILDS`] share it (and the dependencies built there), each ELF is copied to
/// `target/board/nucleo-g474re-<build>.elf` after its build.
const TARGET_DIR: &str = "target/board/fw-remapped";
/// The ELF it builds, under [`TARGET_DIR`].
const ELF: &str = "thumbv7em-none-eabihf/release/nucleo-g474re";
/// Where the figures are written, under the workspace root.
pub const SIZE_JSON: &str = "target/board/size.json";
/// The keys of [`SIZE_JSON`]: the shipped build's, then the bench build's.
pub const KEYS: [&str; 10] = [
    "text",
    "data",
    "bss",
    "flash",
    "ram",
    "bench_text",
    "bench_data",
    "bench_bss",
    "bench_flash",
    "bench_ram",
];
/// The builds measured: a name for the report and the `--features` value (empty: none).
const BUILDS: [(&str, &str); 2] = [("shipped", ""), ("bench", "bench")];
/// Flash of the smallest part the firmware must fit.
pub const FLASH_LIMIT: u64 = 64 * 1024;
/// RAM of that part.
pub const RAM_LIMIT: u64 = 16 * 1024;

/// Berkeley `size` figures of one ELF \[bytes\].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Sizes {
    pub text: u64,
    pub data: u64,
    pub bss: u64,
}

impl Sizes {
    /// Sums the allocated sections of the ELF `data` by kind.
    pub fn of_elf(data: &[u8]) -> Result<Self> {
        let file = object::File::parse(data).map_err(|e| format!("cannot parse the ELF: {e}"))?;
        let mut s = Sizes::default();
        for section in file.sections() {
            let SectionFlags::Elf { sh_flags } = section.flags() else {
                continue;
            };
            if sh_flags & u64::from(SHF_ALLOC) == 0 {
                continue;
            }
            match section.kind() {
                SectionKind::UninitializedData | SectionKind::UninitializedTls => {
                    s.bss += section.size()
                }
                SectionKind::Data | SectionKind::Tls => s.data += section.size(),
                _ => s.text += section.size(),
            }
        }
        Ok(s)
    }

    /// Bytes flash holds: code, read-only data and the initial image of `.data`.
    pub fn flash(&self) -> u64 {
        self.text + self.data
    }

    /// Bytes of RAM taken before the stack.
    pub fn ram(&self) -> u64 {
        self.data + self.bss
    }

    /// Every limit exceeded, one line each.
    pub fn over_limits(&self) -> Vec<String> {
        let mut over = Vec::new();
        if self.flash() > FLASH_LIMIT {
            over.push(format!(
                "flash (text + data) {} B exceeds {} B",
                self.flash(),
                FLASH_LIMIT
            ));
        }
        if self.ram() > RAM_LIMIT {
            over.push(format!(
                "RAM (data + bss) {} B exceeds {} B",
                self.ram(),
                RAM_LIMIT
            ));
        }
        over
    }
}

/// Builds the board firmware as shipped and with `--features bench` (unless `--no-run`: the
/// ELFs as last built), prints their sizes and fails when either is over the limits.
pub fn board_size(opts: &Options) -> Result<()> {
    let dir = workspace_root().join(BOARD_DIR);
    let mut values = Vec::new();
    let mut over = Vec::new();
    for (name, features) in BUILDS {
        let copy = workspace_root().join(format!("target/board/nucleo-g474re-{name}.elf"));
        if !opts.no_run {
            let mut build = firmware_build(&dir, &workspace_root().join(TARGET_DIR));
            if !features.is_empty() {
                build.args(["--features", features]);
            }
            let status = build
                .status()
                .map_err(|e| format!("cannot run cargo: {e}"))?;
            if !status.success() {
                return Err(format!("building {BOARD_DIR} ({name}) failed ({status})"));
            }
            let elf = workspace_root().join(TARGET_DIR).join(ELF);
            std::fs::copy(&elf, &copy).map_err(|e| format!("{}: {e}", elf.display()))?;
        }
        let data = std::fs::read(&copy).map_err(|e| format!("{}: {e}", copy.display()))?;
        let s = Sizes::of_elf(&data)?;
        println!(
            "{BOARD_DIR} ({name}): text {} B, data {} B, bss {} B; flash {} B of {} B, RAM {} B of {} B ({} B left for the stack)",
            s.text,
            s.data,
            s.bss,
            s.flash(),
            FLASH_LIMIT,
            s.ram(),
            RAM_LIMIT,
            RAM_LIMIT.saturating_sub(s.ram())
        );
        values.extend([s.text, s.data, s.bss, s.flash(), s.ram()]);
        over.extend(s.over_limits().into_iter().map(|l| format!("{name}: {l}")));
    }
    let json = workspace_root().join(SIZE_JSON);
    if let Some(d) = json.parent() {
        std::fs::create_dir_all(d).map_err(|e| format!("{}: {e}", d.display()))?;
    }
    let map: serde_json::Map<String, serde_json::Value> = KEYS
        .iter()
        .zip(values)
        .map(|(k, v)| ((*k).to_owned(), v.into()))
        .collect();
    std::fs::write(&json, serde_json::Value::Object(map).to_string())
        .map_err(|e| format!("{}: {e}", json.display()))?;
    if over.is_empty() {
        Ok(())
    } else {
        Err(over.join("; "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_at_the_limits_pass_and_one_byte_over_fails() {
        let at = Sizes {
            text: FLASH_LIMIT - 100,
            data: 100,
            bss: RAM_LIMIT - 100,
        };
        assert!(at.over_limits().is_empty());
        let over = Sizes { data: 101, ..at };
        let lines = over.over_limits();
        assert_eq!(lines.len(), 2, "{lines:?}");
        assert!(lines[0].starts_with("flash"));
        assert!(lines[1].starts_with("RAM"));
    }
}
