//! Project tasks, run as `cargo xtask <task>` (the alias lives in `.cargo/config.toml`).
//!
//! * `bench-target`: the cost of one `Controller::step` (and of a node's `Node::tick`) on every
//!   Cortex-M class: builds `bench-fw` per core and variant, runs it on the core's QEMU machine
//!   with `-icount shift=0`, reads instructions per step (min / median / max), peak stack and
//!   state size from its semihosting output and the controller's flash from the ELF's symbol
//!   sizes; writes `target/bench/step.json` and prints a table; then measures the cores without
//!   an FPU further (`softfloat.rs`: operations, profile) into `target/bench/softfloat.json`.
//! * `bench-gate`: `bench-target`, then fails when a variant's median or maximum instructions,
//!   stack, step flash, configuration flash or state size are more than the budget's tolerance
//!   (10 %) above `bench-fw/budget.json`, when an Example 1 step variant on a core with an FPU
//!   has a stack above 512 B or a step plus configuration flash above 16 KiB, or when a replayed step faulted; it
//!   prints the reasons the budget gives for raised figures. `--update-budget` rewrites the
//!   budget and refuses a figure raised beyond the tolerance without `--reason` (details:
//!   `gate.rs`).
//! * `docs`: rewrites the measured figures of `README.md` and `docs/*.md` between their markers
//!   from the files the measuring commands write; `--check` fails naming each block that differs
//!   (details: `docs.rs`).
//!
//! * `reproduction`: re-makes every table, figure and image of `docs/REPRODUCTION.md` from
//!   scratch and states the time it took in that document (details: `docs.rs`).
//! * `board-size`: builds the board firmware `boards/nucleo-g474re` in release, as shipped and
//!   with `--features bench`, and fails when either's flash (text + data) exceeds 64 KiB or its
//!   RAM (data + bss) 16 KiB (details: `board.rs`).
//! * `doc-coverage`: rustdoc's documentation coverage of controller-core and agent-node with a
//!   pinned nightly; fails on an undocumented item or an item without a runnable example
//!   (details: `doccov.rs`).
//! * `vm`: runs a command in a Linux guest that has CAN (`vcan0`, optional SJA1000
//!   controllers) with the repository at the same path (details: `vm.rs`).
//!
//! Nothing is installed system-wide (`vm` unpacks its packages under `target/vm/`): a missing
//! `qemu-system-arm` or `thumbv7em-none-eabihf` target is reported with the command that
//! installs it.

mod bench;
mod board;
mod doccov;
mod docs;
mod flash;
mod gate;
mod softfloat;
mod target;
mod task;
mod trace;
mod trace_load;
mod vm;

use std::process::ExitCode;

use task::Options;

const USAGE: &str = "\
usage: cargo xtask <task> [options]

tasks:
  bench-target [--verbose]
      build bench-fw for each core and variant, run it on the core's QEMU machine (-icount
      shift=0: microbit Cortex-M0, mps2-an385 M3, mps2-an386 M4F, mps2-an500 M7, mps2-an505
      M33), write target/bench/step.json and print a table; then, on the cores without an
      FPU, the instructions per f32 / fixed-point operation and the soft-float step's profile
      (target/bench/softfloat.json)
  bench-gate [--no-run] [--update-budget [--reason TEXT]]
      bench-target (unless --no-run), then fail if
        - a variant's instructions (median, max), stack, step flash, configuration flash or
          state bytes exceed bench-fw/budget.json by more than its tolerance (10 %);
        - an Example 1 (n2m2) step variant on a core with an FPU has a stack above 512 B,
          or its step flash plus configuration flash exceeds 16 KiB (16,384 B);
        - a variant faulted on a step, ran no step or is missing;
      and print every reason the budget gives for a raised figure.
      --update-budget writes the budget from the measured figures instead; a figure above
      the committed budget by more than its tolerance is refused unless --reason TEXT
      explains it (written next to the figure as `<figure>_reason`)
  docs [--check] [--rerun] [--wall-clock] [--list] [--only FILE|NAME]
      rewrite every measured figure of README.md and docs/*.md between its
      <!-- fig:NAME --> and <!-- /fig:NAME --> markers from the files the measuring
      commands write (reused when present; --rerun measures again); --check writes
      nothing and fails naming each block that differs; wall-clock figures (wall.*)
      are rewritten only with --wall-clock and never checked; --list names the figures;
      --only FILE (e.g. docs/CLOCKS.md) handles that document alone; --only NAME renders (or
      checks) the blocks of figure NAME alone. The documents' images (campaign maps, fault
      matrices, run figures) are copied from the figures the commands draw, and checked
      byte for byte, with every document or with --only images
  reproduction
      re-make every table, figure and image of docs/REPRODUCTION.md from scratch (every
      source measured again, the readings table's runs at h = 1 us included: tens of
      minutes) and write the time it took, with the date and the machine, into the
      document's `wall.reproduction` block
  board-size [--no-run]
      build boards/nucleo-g474re in release, as shipped and with --features bench (unless
      --no-run: the ELFs as last built), print their text, data and bss, and fail if either's
      text + data exceeds 64 KiB (65,536 B) or data + bss exceeds 16 KiB (16,384 B); writes
      target/board/size.json
  doc-coverage
      rustdoc's coverage report of controller-core (default features and serde) and of
      agent-node (default features) with the pinned nightly-2026-05-19; fail if an item lacks
      documentation or fewer items than the count reached per crate (xtask/src/doccov.rs)
      carry a runnable example
  trace-load <candump log> --bitrate B [--data-bitrate D] [--h S]
      the bus time per sample (one leader value frame) of the frames of a `--trace` log, by
      frame kind, with the worst-case bit lengths of agent_node::bus_load at the given bit
      rates (CAN FD lines with bit-rate switching at D), and its share of h (default 1 ms)
  vm [--can N] [--bitrate B] [--mem MIB] [--smp N] [--timeout S] [--verbose] -- <command…>
      boot a QEMU x86_64 Linux guest (Debian kernel, busybox initramfs, cached under
      target/vm/) with vcan0 up (and can0..canN-1 on emulated Kvaser PCI SJA1000
      controllers with --can N), the host root read-only and this repository writable at
      the same path; run the command there and exit with its status
";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(task) = args.first() else {
        eprint!("{USAGE}");
        return ExitCode::from(2);
    };
    if task == "trace-load" {
        return match trace_load::trace_load(&args[1..]) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        };
    }
    if task == "vm" {
        return vm::vm(&args[1..]).unwrap_or_else(|e| {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        });
    }
    let opts = match Options::parse(&args[1..]) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let result = match task.as_str() {
        "bench-target" => bench::bench_target(&opts).map(|_| ()),
        "bench-gate" => gate::bench_gate(&opts),
        "docs" => docs::docs(&opts),
        "reproduction" => docs::reproduction(&opts),
        "board-size" => board::board_size(&opts),
        "doc-coverage" => doccov::doc_coverage(),
        "help" | "--help" | "-h" => {
            print!("{USAGE}");
            Ok(())
        }
        other => {
            eprintln!("error: unknown task `{other}`\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
