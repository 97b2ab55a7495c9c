#!/usr/bin/env bash
# CI stage "board": the NUCLEO-G474RE node firmware (boards/nucleo-g474re) is formatted,
# clippy-clean, builds in release from its lock file, and fits a 64 KiB-flash / 16 KiB-RAM part
# (`cargo xtask board-size` reads the ELF itself: no binutils needed). It is compiled here, not
# run: no emulator models the STM32 clock tree or FDCAN.
# Needs only the host Rust toolchain; installs the thumbv7em-none-eabihf target, rustfmt and
# clippy if missing.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never

rustup target list --installed | grep -qx thumbv7em-none-eabihf || rustup target add thumbv7em-none-eabihf
rustup component add rustfmt clippy 2>/dev/null || true

(
  cd boards/nucleo-g474re
  cargo fmt --check
  cargo clippy --release --locked -- -D warnings
)
# Builds the board in release, prints text / data / bss, fails over the limits.
cargo xtask board-size
