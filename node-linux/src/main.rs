//! `node-linux <config.toml> [--interface IF]`: one follower agent on a SocketCAN interface
//! (docs/NETWORK.md, "Linux CAN"). Exit status 0 when stopped by SIGINT/SIGTERM or when the
//! host fell silent, 2 for a bad configuration, 1 when the interface cannot be used.

use std::{
    path::PathBuf,
    process::ExitCode,
    sync::{atomic::AtomicBool, Arc},
};

use node_linux::{run, NodeFile};

const USAGE: &str = "usage: node-linux <config.toml> [--interface IF]";

struct StderrLog;

impl log::Log for StderrLog {
    fn enabled(&self, m: &log::Metadata<'_>) -> bool {
        m.level() <= log::Level::Info
    }
    fn log(&self, r: &log::Record<'_>) {
        if self.enabled(r.metadata()) {
            // One write per line, so the lines of several nodes on one terminal stay whole.
            let line = format!("node-linux {}: {}\n", r.level(), r.args());
            let _ = std::io::Write::write_all(&mut std::io::stderr().lock(), line.as_bytes());
        }
    }
    fn flush(&self) {}
}

fn main() -> ExitCode {
    let _ = log::set_logger(&StderrLog).map(|()| log::set_max_level(log::LevelFilter::Info));
    let mut args = std::env::args().skip(1);
    let mut path: Option<PathBuf> = None;
    let mut interface: Option<String> = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--interface" => interface = args.next(),
            "-h" | "--help" => {
                println!("{USAGE}");
                return ExitCode::SUCCESS;
            }
            _ if path.is_none() && !a.starts_with('-') => path = Some(PathBuf::from(a)),
            other => {
                eprintln!("error: unexpected argument `{other}`\n{USAGE}");
                return ExitCode::from(2);
            }
        }
    }
    let Some(path) = path else {
        eprintln!("error: no configuration file\n{USAGE}");
        return ExitCode::from(2);
    };
    let cfg = match NodeFile::load(&path).and_then(|mut c| {
        if let Some(i) = interface {
            c.node.interface = i;
        }
        NodeFile::new(c.node, controller_core::ConfigFile::from(c.controller))
    }) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {}: {e}", path.display());
            return ExitCode::from(2);
        }
    };
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    if let Err(e) =
        ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::Relaxed))
    {
        eprintln!("error: signal handler: {e}");
        return ExitCode::FAILURE;
    }
    match run::run(&cfg, &stop) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
