//! The images of `README.md` and `docs/`: each is a copy of a figure that a measuring command
//! writes (a shipped campaign's map, a fault matrix, a run's figure). `cargo xtask docs` copies
//! them from the current outputs; `--check` names every image whose bytes differ, so an image
//! drawn by older code cannot stay in the documents.

use std::{fs, process::Command};

use super::{run, Sources};
use crate::task::{workspace_root, Result};

/// Where an image comes from.
enum Source {
    /// A file beside `out/campaigns/NAME/results.csv` (a shipped campaign).
    Campaign(&'static str, &'static str),
    /// `matrix.png` of `target/fault-matrix/CASE/`.
    Matrix(&'static str),
    /// The torque-limit sweep's figure (`target/torque-limit/`).
    Torque,
    /// Lemma 2's envelope against the measured `½ Σ e²` (`target/docs/claims/`).
    Lemma2,
    /// The settling-time vs energy front of `host-sim/tests/front.rs` (`target/front/`).
    Front,
    /// A figure of `host-sim ARGS --out target/docs/images/TAG/`.
    Run {
        tag: &'static str,
        args: &'static [&'static str],
        file: &'static str,
    },
}

/// Every image of the documents and its source.
const IMAGES: [(&str, Source); 18] = [
    ("docs/figures/lemma2-envelope.svg", Source::Lemma2),
    (
        "host-sim/doc/example1-errors.png",
        Source::Run {
            tag: "example1",
            args: &["run", "scenarios/example1.toml", "--quiet"],
            file: "errors.png",
        },
    ),
    (
        "docs/figures/clocks-example1-can.png",
        Source::Run {
            tag: "example1-can-clocks",
            args: &[
                "run",
                "scenarios/example1-can.toml",
                "--quiet",
                "--set",
                "clock.drift_ppm=[100, -100, 100, -100]",
                "--set",
                "clock.jitter_us=20",
                "--set",
                "clock.offset_us=200",
            ],
            file: "clocks.png",
        },
    ),
    (
        "docs/campaigns/clock-drift-map-none.png",
        Source::Campaign("clock-drift", "map-1.png"),
    ),
    (
        "docs/campaigns/clock-drift-example2-map-none.png",
        Source::Campaign("clock-drift-example2", "map-1.png"),
    ),
    (
        "docs/campaigns/clock-drift-example2-map-leader.png",
        Source::Campaign("clock-drift-example2", "map-2.png"),
    ),
    (
        "docs/campaigns/clock-drift-example2-montecarlo.png",
        Source::Campaign("clock-drift-example2", "montecarlo.png"),
    ),
    (
        "docs/campaigns/example1-monte-carlo.png",
        Source::Campaign("example1-monte-carlo", "montecarlo.png"),
    ),
    (
        "docs/campaigns/example1-ts-h.png",
        Source::Campaign("example1-ts-h", "map.png"),
    ),
    (
        "docs/campaigns/example2-ts-h.png",
        Source::Campaign("example2-ts-h", "map.png"),
    ),
    (
        "docs/figures/fault-matrix-example1.png",
        Source::Matrix("example1"),
    ),
    (
        "docs/figures/fault-matrix-example2-deploy.png",
        Source::Matrix("example2"),
    ),
    (
        "docs/figures/fault-matrix-example2-fast.png",
        Source::Matrix("example2-fast"),
    ),
    ("docs/figures/torque-limit.png", Source::Torque),
    ("docs/figures/example2-front.png", Source::Front),
    (
        "docs/campaigns/example2-baseline-retune.png",
        Source::Campaign("example2-baseline-retune", "map.png"),
    ),
    (
        "docs/figures/example2-compare-outputs.png",
        Source::Run {
            tag: "example2-compare",
            args: &[
                "compare",
                "scenarios/example2.toml",
                "scenarios/example2-baseline.toml",
            ],
            file: "compare-outputs.png",
        },
    ),
    (
        "docs/figures/example1-inputs-print.png",
        Source::Run {
            tag: "example1-print",
            args: &[
                "run",
                "scenarios/example1.toml",
                "--quiet",
                "--set",
                "figures.width_mm=85",
                "--set",
                "figures.height_mm=55",
                "--set",
                "figures.font_pt=8",
                "--set",
                "figures.dpi=300",
                "--set",
                "figures.format=[\"png\"]",
            ],
            file: "inputs-2.png",
        },
    ),
];

impl Sources {
    /// The current file an image copies, produced when missing (or with `--rerun`).
    fn image_source(&mut self, source: &Source) -> Result<std::path::PathBuf> {
        match *source {
            Source::Campaign(name, file) => {
                self.campaign(name)?;
                Ok(workspace_root().join(format!("out/campaigns/{name}/{file}")))
            }
            Source::Matrix(case) => {
                self.matrix(case)?;
                Ok(workspace_root().join(format!("target/fault-matrix/{case}/matrix.png")))
            }
            Source::Lemma2 => super::claims::envelope_figure(self),
            Source::Torque => {
                self.torque()?;
                Ok(workspace_root().join("target/torque-limit/torque-limit.png"))
            }
            Source::Front => self.file("target/front/front.png", |_, path| {
                run(Command::new(crate::task::cargo())
                    .current_dir(workspace_root())
                    .env("FRONT_OUT", path.parent().unwrap_or(path))
                    .args(["test", "-p", "host-sim", "--release", "--test", "front"])
                    .args(["--", "--ignored"]))
                .map(|_| ())
            }),
            Source::Run { tag, args, file } => {
                self.file(&format!("target/docs/images/{tag}/{file}"), |s, path| {
                    let bin = s.host_sim()?;
                    run(Command::new(bin)
                        .current_dir(workspace_root())
                        .args(args)
                        .arg("--out")
                        .arg(path.parent().unwrap_or(path)))
                    .map(|_| ())
                })
            }
        }
    }
}

/// Copies every image from its source or, with `check`, lists those that differ; with
/// `shown_in`, only the images that document text links (paths relative to `docs/`).
pub(super) fn images(
    src: &mut Sources,
    check: bool,
    shown_in: Option<&str>,
) -> Result<Vec<String>> {
    let mut differ = Vec::new();
    let shown = |doc: &str| {
        shown_in
            .is_none_or(|text| text.contains(&format!("]({})", doc.trim_start_matches("docs/"))))
    };
    for (doc, source) in IMAGES.iter().filter(|(doc, _)| shown(doc)) {
        let from = src.image_source(source)?;
        let new = fs::read(&from).map_err(|e| format!("{}: {e}", from.display()))?;
        let path = workspace_root().join(doc);
        if fs::read(&path).ok().as_deref() == Some(&new[..]) {
            continue;
        }
        let rel = from
            .strip_prefix(workspace_root())
            .unwrap_or(&from)
            .display()
            .to_string();
        if check {
            differ.push(format!("{doc}: image differs from {rel}"));
        } else {
            fs::write(&path, &new).map_err(|e| format!("{doc}: {e}"))?;
            println!("{doc}: copied from {rel}");
        }
    }
    Ok(differ)
}
