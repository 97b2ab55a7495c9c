#!/usr/bin/env bash
# CI stage "board": the NUCLEO-G474RE node firmware (boards/nucleo-g474re) is formatted,
# clippy-clean as shipped and with its bench feature, its board-independent logic (output gate,
# bus-off recovery, FDCAN and IWDG register values, PWM/encoder arithmetic, reset cause and boot
# count, plant-bus sensor and actuator, the stored configuration's page and boot decision) passes
# its host tests, and both builds fit a
# 64 KiB-flash / 16 KiB-RAM part (`cargo xtask board-size` builds them in release from the lock
# file and reads the ELFs itself: no binutils needed). The firmware is compiled here, not run:
# no emulator models the STM32 clock tree or FDCAN.
# Needs only the host Rust toolchain; installs the thumbv7em-none-eabihf target, rustfmt and
# clippy if missing.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never

rustup target list --installed | grep -qx thumbv7em-none-eabihf || rustup target add thumbv7em-none-eabihf
rustup component add rustfmt clippy 2>/dev/null || true
host=$(rustc -vV | sed -n 's/^host: //p')

(
  cd boards/nucleo-g474re
  cargo fmt --check
  cargo clippy --release --locked -- -D warnings
  cargo clippy --release --locked --features bench -- -D warnings
  # The library's pure modules on the host (the binary builds only for the board).
  cargo clippy --locked --lib --tests --target "$host" -- -D warnings
  cargo test --locked --lib --target "$host"
)
# Builds the board in release as shipped and with --features bench, prints text / data / bss,
# fails over the limits.
cargo xtask board-size
