//! `node-linux <config.toml> [--interface IF]`: one follower agent on a SocketCAN interface
//! (docs/NETWORK.md §11, "Linux CAN"; `--interface` replaces the file's `node.interface`).
//! Exit status: 0 stopped by the master's NMT stop (with `[node.canopen] exit_on_stop`) or by
//! SIGINT/SIGTERM; 2 bad configuration or usage (before any socket is opened, naming the key); 1
//! the interface cannot be used; 3 the host went silent (`host_timeout`) or never came
//! (`start_timeout`), said on the bus by EMCY `0x8250` (cause 10).

use std::{
    path::PathBuf,
    process::ExitCode,
    sync::{atomic::AtomicBool, Arc, Mutex},
    time::{Duration, Instant},
};

use node_linux::{run, NodeFile};

const USAGE: &str = "usage: node-linux <config.toml> [--interface IF]";

/// Log lines on stderr; a line logged again within [`REPEAT_WINDOW`] of its last print is held
/// back and counted, and the count is printed with its next print or the next other line.
struct StderrLog(Mutex<Repeats>);

/// How long the same log line is held back after it was printed.
const REPEAT_WINDOW: Duration = Duration::from_secs(1);

#[derive(Default)]
struct Repeats {
    /// The last line printed, when, and how often it came again since.
    last: Option<(String, Instant, u64)>,
}

impl Repeats {
    /// The text to print for `line` at `now` (`None`: held back as a repeat).
    fn admit(&mut self, line: String, now: Instant) -> Option<String> {
        let mut out = String::new();
        if let Some((last, at, held)) = self.last.as_mut() {
            if *last == line {
                if now.saturating_duration_since(*at) < REPEAT_WINDOW {
                    *held += 1;
                    return None;
                }
                if *held > 0 {
                    out = format!(
                        "{line} (and {held} more times in the last {:.1} s)\n",
                        now.saturating_duration_since(*at).as_secs_f64()
                    );
                    *at = now;
                    *held = 0;
                    return Some(out);
                }
            } else if *held > 0 {
                out = format!("{last} (repeated {held} more times)\n");
            }
        }
        out.push_str(&line);
        out.push('\n');
        self.last = Some((line, now, 0));
        Some(out)
    }
}

impl log::Log for StderrLog {
    fn enabled(&self, m: &log::Metadata<'_>) -> bool {
        m.level() <= log::Level::Info
    }
    fn log(&self, r: &log::Record<'_>) {
        if self.enabled(r.metadata()) {
            let line = format!("node-linux {}: {}", r.level(), r.args());
            let text = match self.0.lock() {
                Ok(mut rep) => rep.admit(line, Instant::now()),
                Err(_) => Some(format!("{line}\n")),
            };
            // One write per line, so the lines of several nodes on one terminal stay whole.
            if let Some(t) = text {
                let _ = std::io::Write::write_all(&mut std::io::stderr().lock(), t.as_bytes());
            }
        }
    }
    fn flush(&self) {}
}

static LOG: StderrLog = StderrLog(Mutex::new(Repeats { last: None }));

fn main() -> ExitCode {
    let _ = log::set_logger(&LOG).map(|()| log::set_max_level(log::LevelFilter::Info));
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
        Ok(reason) => ExitCode::from(reason.exit_status()),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_repeated_within_a_second_is_counted_not_printed() {
        let mut r = Repeats::default();
        let t0 = Instant::now();
        let ms = |n: u64| t0 + Duration::from_millis(n);
        assert_eq!(r.admit("a".into(), ms(0)), Some("a\n".into()));
        assert_eq!(r.admit("a".into(), ms(10)), None);
        assert_eq!(r.admit("a".into(), ms(20)), None);
        assert_eq!(
            r.admit("b".into(), ms(30)),
            Some("a (repeated 2 more times)\nb\n".into())
        );
        assert_eq!(r.admit("b".into(), ms(40)), None);
        assert_eq!(
            r.admit("b".into(), ms(1500)),
            Some("b (and 1 more times in the last 1.5 s)\n".into())
        );
        assert_eq!(r.admit("b".into(), ms(3000)), Some("b\n".into()));
    }
}
