//! `cargo xtask vm -- <command…>`: runs a command inside a Linux test VM that has CAN.
//!
//! The build machines' kernel has no `AF_CAN`, so everything that opens a CAN socket runs in a
//! QEMU x86_64 guest (TCG) with Debian's kernel. The guest is an initramfs of `busybox` and the
//! CAN and 9p modules; it mounts the host's root read-only and the repository (with its
//! `target/`) writable at the same path, `chroot`s into the host root, brings up `vcan0` (and
//! `can0..canN-1` on emulated Kvaser PCI SJA1000 controllers sharing one QEMU CAN bus with
//! `--can N`) and runs the command in the repository's directory. Its output is the console
//! between two markers; its exit status is written to a file in the writable share.
//!
//! Everything downloaded (`apt-get download` + `dpkg -x`, no root needed) and the initramfs are
//! cached under `target/vm/`.

use std::{
    fs,
    io::{BufRead, BufReader, Read, Write},
    path::{Path, PathBuf},
    process::{Command, ExitCode, Stdio},
    sync::mpsc,
    time::{Duration, Instant},
};

use crate::task::{workspace_root, Result};

/// Kernel modules of the initramfs, in load order.
const MODULES: &[&str] = &[
    "virtio_ring",
    "virtio",
    "virtio_pci_modern_dev",
    "virtio_pci_legacy_dev",
    "virtio_pci",
    "9pnet",
    "9pnet_virtio",
    "netfs",
    "fscache",
    "9p",
    "can",
    "can-raw",
    "can-dev",
    "vcan",
    "sja1000",
    "kvaser_pci",
];

const BEGIN: &str = "==xtask-vm-begin==";
const END: &str = "==xtask-vm-end==";

/// Environment variables carried from the host into the guest command.
const PASS_ENV: &[&str] = &[
    "PATH",
    "HOME",
    "USER",
    "CARGO_HOME",
    "RUSTUP_HOME",
    "CARGO_TARGET_DIR",
    "RUST_LOG",
    "RUST_BACKTRACE",
    "PROPTEST_RNG_SEED",
];

const VM_USAGE: &str = "\
usage: cargo xtask vm [--can N] [--bitrate B] [--mem MIB] [--smp N] [--timeout S] [--verbose] -- <command…>
  --can N       N emulated Kvaser PCI (SJA1000) controllers on one QEMU CAN bus: can0..canN-1,
                brought up at --bitrate (default 1000000) before the command runs
  --mem MIB     guest memory (default 1024)
  --smp N       guest processors (default 2)
  --timeout S   stop the guest after S seconds of wall time (default 600); exit status 124
  --verbose     print the boot console too";

struct VmOptions {
    can: u32,
    bitrate: u32,
    mem_mib: u32,
    smp: u32,
    timeout: Duration,
    verbose: bool,
    command: Vec<String>,
}

impl VmOptions {
    fn parse(args: &[String]) -> Result<Self> {
        let mut o = VmOptions {
            can: 0,
            bitrate: 1_000_000,
            mem_mib: 1024,
            smp: 2,
            timeout: Duration::from_secs(600),
            verbose: false,
            command: Vec::new(),
        };
        let mut it = args.iter();
        while let Some(a) = it.next() {
            let mut num = |name: &str| -> Result<u32> {
                let v = it.next().ok_or(format!("{name} needs a value"))?;
                v.parse()
                    .map_err(|_| format!("{name}: `{v}` is not a non-negative integer"))
            };
            match a.as_str() {
                "--can" => o.can = num("--can")?,
                "--bitrate" => o.bitrate = num("--bitrate")?,
                "--mem" => o.mem_mib = num("--mem")?,
                "--smp" => o.smp = num("--smp")?.max(1),
                "--timeout" => o.timeout = Duration::from_secs(u64::from(num("--timeout")?)),
                "--verbose" | "-v" => o.verbose = true,
                "--" => {
                    o.command = it.cloned().collect();
                    break;
                }
                "-h" | "--help" => return Err(VM_USAGE.to_owned()),
                other => return Err(format!("unknown option `{other}`\n{VM_USAGE}")),
            }
        }
        if o.command.is_empty() {
            return Err(format!("no command given\n{VM_USAGE}"));
        }
        Ok(o)
    }
}

/// Entry point of `cargo xtask vm`: the guest command's exit status becomes ours.
pub fn vm(args: &[String]) -> std::result::Result<ExitCode, String> {
    let opts = VmOptions::parse(args)?;
    let root = workspace_root();
    let dir = root.join("target").join("vm");
    let t0 = Instant::now();
    let assets = Assets::prepare(&dir)?;
    let initramfs = build_initramfs(&dir, &assets)?;
    let run_dir = dir.join("run").join(std::process::id().to_string());
    fs::create_dir_all(&run_dir).map_err(|e| format!("{}: {e}", run_dir.display()))?;
    let status_file = run_dir.join("status");
    let _ = fs::remove_file(&status_file);
    fs::write(run_dir.join("cmd.sh"), command_script(&root, &opts))
        .map_err(|e| format!("{}: {e}", run_dir.display()))?;
    let code = boot(&assets, &initramfs, &root, &run_dir, &opts, t0)?;
    let status = fs::read_to_string(&status_file).ok();
    let _ = fs::remove_dir_all(&run_dir);
    match (code, status) {
        (BootEnd::TimedOut, _) => {
            eprintln!(
                "xtask vm: guest stopped after the {} s timeout",
                opts.timeout.as_secs()
            );
            Ok(ExitCode::from(124))
        }
        (BootEnd::Exited, Some(s)) => {
            let s: u8 = s.trim().parse().unwrap_or(1);
            eprintln!(
                "xtask vm: command exited with status {s} after {:.1} s (boot included)",
                t0.elapsed().as_secs_f64()
            );
            Ok(ExitCode::from(s))
        }
        (BootEnd::Exited, None) => Err(
            "the guest stopped without running the command (rerun with --verbose to see the boot)"
                .to_owned(),
        ),
    }
}

/// The guest's shell script: interfaces up, then the command in the repository's directory.
fn command_script(root: &Path, opts: &VmOptions) -> String {
    let mut s = String::from("set -e\n");
    for key in PASS_ENV {
        if let Ok(v) = std::env::var(key) {
            s += &format!("export {key}={}\n", quote(&v));
        }
    }
    s += "ip link set lo up\nip link add dev vcan0 type vcan\nip link set vcan0 up\n";
    for i in 0..opts.can {
        s += &format!(
            "ip link set can{i} type can bitrate {}\nip link set can{i} up\n",
            opts.bitrate
        );
    }
    s += &format!("cd {}\nset +e\n", quote(&root.display().to_string()));
    // Output through a pipe, not the console's tty: no progress bars or colours in the log.
    s += "out=/tmp/xtask-vm-out\nmkfifo \"$out\"\ncat \"$out\" &\nexec >\"$out\" 2>&1 </dev/null\n";
    let cmd: Vec<String> = opts.command.iter().map(|a| quote(a)).collect();
    s += &cmd.join(" ");
    s += "\nstatus=$?\nexec >&- 2>&-\nwait\nexit $status\n";
    s
}

/// POSIX shell single-quoting.
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The busybox `/init` of the guest.
fn init_script() -> String {
    let modules = MODULES.join(" ");
    format!(
        r#"#!/bin/sh
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
for m in {modules}; do insmod /lib/modules/$m.ko || echo "insmod $m failed"; done
opts=trans=virtio,version=9p2000.L,msize=512000
mount -t 9p -o $opts,ro hostroot /host || echo "mount of the host root failed"
mount -t 9p -o $opts repo "/host$XTASK_REPO" || echo "mount of the repository failed"
mount -t proc proc /host/proc
mount -t sysfs sys /host/sys
mount -t devtmpfs dev /host/dev
mkdir -p /host/dev/pts /host/dev/shm 2>/dev/null
mount -t devpts devpts /host/dev/pts
mount -t tmpfs shm /host/dev/shm
mount -t tmpfs tmp /host/tmp
mount -t tmpfs run /host/run
echo "{BEGIN}"
chroot /host /bin/sh "$XTASK_RUN/cmd.sh" < /dev/null
echo $? > "/host$XTASK_RUN/status"
echo "{END}"
sync
poweroff -f
"#
    )
}

/// Paths of the unpacked kernel, modules, busybox and QEMU.
struct Assets {
    kernel: PathBuf,
    modules: PathBuf,
    busybox: PathBuf,
    qemu: PathBuf,
    qemu_data: Vec<PathBuf>,
    qemu_modules: Option<PathBuf>,
}

impl Assets {
    fn prepare(dir: &Path) -> Result<Self> {
        let root = dir.join("root");
        let kernel_pkg = kernel_package(dir)?;
        unpack(dir, &kernel_pkg)?;
        unpack(dir, "busybox-static")?;
        let version = kernel_pkg.trim_start_matches("linux-image-").to_owned();
        let (qemu, qemu_data) = match which("qemu-system-x86_64") {
            Some(q) => (q, Vec::new()),
            None => {
                for pkg in [
                    "qemu-system-x86",
                    "qemu-system-common",
                    "qemu-system-data",
                    "seabios",
                ] {
                    unpack(dir, pkg)?;
                }
                let data = vec![root.join("usr/share/seabios"), root.join("usr/share/qemu")];
                (root.join("usr/bin/qemu-system-x86_64"), data)
            }
        };
        Ok(Assets {
            kernel: root.join(format!("boot/vmlinuz-{version}")),
            modules: root.join(format!("lib/modules/{version}")),
            busybox: root.join("bin/busybox"),
            qemu_modules: (!qemu_data.is_empty())
                .then(|| root.join("usr/lib/x86_64-linux-gnu/qemu")),
            qemu,
            qemu_data,
        })
    }
}

fn which(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|p| {
        std::env::split_paths(&p)
            .map(|d| d.join(name))
            .find(|f| f.is_file())
    })
}

/// The versioned kernel package `linux-image-amd64` depends on (remembered in `target/vm`).
fn kernel_package(dir: &Path) -> Result<String> {
    let cache = dir.join("kernel-package");
    if let Ok(s) = fs::read_to_string(&cache) {
        return Ok(s.trim().to_owned());
    }
    let out = Command::new("apt-cache")
        .args(["depends", "linux-image-amd64"])
        .output()
        .map_err(|e| format!("apt-cache (Debian's apt is needed to fetch the VM kernel): {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let pkg = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix("Depends: "))
        .find(|p| p.starts_with("linux-image-") && p.ends_with("-amd64"))
        .ok_or("apt-cache depends linux-image-amd64 names no kernel package (run apt-get update)")?
        .to_owned();
    fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    fs::write(&cache, &pkg).map_err(|e| format!("{}: {e}", cache.display()))?;
    Ok(pkg)
}

/// `apt-get download` + `dpkg -x` of one package into `target/vm/root`, once.
fn unpack(dir: &Path, pkg: &str) -> Result<()> {
    let stamp = dir.join("unpacked").join(pkg);
    if stamp.exists() {
        return Ok(());
    }
    let debs = dir.join("debs");
    fs::create_dir_all(&debs).map_err(|e| format!("{}: {e}", debs.display()))?;
    eprintln!("xtask vm: downloading {pkg}");
    run(Command::new("apt-get")
        .args(["download", pkg])
        .current_dir(&debs))?;
    let deb = fs::read_dir(&debs)
        .map_err(|e| format!("{}: {e}", debs.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(&format!("{pkg}_")) && n.ends_with(".deb"))
        })
        .ok_or(format!("apt-get download {pkg} left no .deb"))?;
    run(Command::new("dpkg")
        .arg("-x")
        .arg(&deb)
        .arg(dir.join("root")))?;
    fs::create_dir_all(dir.join("unpacked")).map_err(|e| format!("{}: {e}", dir.display()))?;
    fs::write(&stamp, deb.display().to_string()).map_err(|e| format!("{}: {e}", stamp.display()))
}

fn run(cmd: &mut Command) -> Result<()> {
    let st = cmd.status().map_err(|e| format!("{cmd:?}: {e}"))?;
    if st.success() {
        Ok(())
    } else {
        Err(format!("{cmd:?} failed: {st}"))
    }
}

/// Writes `target/vm/initramfs.cpio` (newc) when its content changed.
fn build_initramfs(dir: &Path, assets: &Assets) -> Result<PathBuf> {
    let mut cpio = Cpio::default();
    for d in ["bin", "dev", "proc", "sys", "host", "lib", "lib/modules"] {
        cpio.dir(d);
    }
    let busybox = read(&assets.busybox)?;
    cpio.file("bin/busybox", &busybox, 0o755);
    for applet in [
        "sh", "mount", "insmod", "mkdir", "chroot", "echo", "sync", "poweroff",
    ] {
        cpio.symlink(&format!("bin/{applet}"), "busybox");
    }
    cpio.file("init", init_script().as_bytes(), 0o755);
    for m in MODULES {
        let path = find_module(&assets.modules, m)?;
        cpio.file(&format!("lib/modules/{m}.ko"), &read(&path)?, 0o644);
    }
    let bytes = cpio.finish();
    let path = dir.join("initramfs.cpio");
    if fs::read(&path).ok().as_deref() != Some(&bytes[..]) {
        fs::write(&path, &bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(path)
}

fn read(p: &Path) -> Result<Vec<u8>> {
    fs::read(p).map_err(|e| format!("{}: {e}", p.display()))
}

fn find_module(dir: &Path, name: &str) -> Result<PathBuf> {
    let file = format!("{name}.ko");
    let mut stack = vec![dir.join("kernel")];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).map_err(|e| format!("{}: {e}", d.display()))? {
            let p = e.map_err(|e| e.to_string())?.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().and_then(|n| n.to_str()) == Some(file.as_str()) {
                return Ok(p);
            }
        }
    }
    Err(format!(
        "kernel module {file} not found under {}",
        dir.display()
    ))
}

/// A `newc` cpio archive, the format the kernel unpacks as initramfs.
#[derive(Default)]
struct Cpio {
    out: Vec<u8>,
    ino: u32,
}

impl Cpio {
    fn entry(&mut self, name: &str, mode: u32, data: &[u8]) {
        self.ino += 1;
        let header = format!(
            "070701{:08x}{:08x}{:08x}{:08x}{:08x}{:08x}{:08x}{:08x}{:08x}{:08x}{:08x}{:08x}{:08x}",
            self.ino,
            mode,
            0,
            0,
            1,
            0,
            data.len(),
            0,
            0,
            0,
            0,
            name.len() + 1,
            0
        );
        self.out.extend_from_slice(header.as_bytes());
        self.out.extend_from_slice(name.as_bytes());
        self.out.push(0);
        self.pad();
        self.out.extend_from_slice(data);
        self.pad();
    }
    fn pad(&mut self) {
        while !self.out.len().is_multiple_of(4) {
            self.out.push(0);
        }
    }
    fn dir(&mut self, name: &str) {
        self.entry(name, 0o040_755, &[]);
    }
    fn file(&mut self, name: &str, data: &[u8], perm: u32) {
        self.entry(name, 0o100_000 | perm, data);
    }
    fn symlink(&mut self, name: &str, target: &str) {
        self.entry(name, 0o120_777, target.as_bytes());
    }
    fn finish(mut self) -> Vec<u8> {
        self.entry("TRAILER!!!", 0, &[]);
        self.out
    }
}

enum BootEnd {
    Exited,
    TimedOut,
}

/// Boots the guest, streams the command's output, and waits for the guest to power off.
fn boot(
    assets: &Assets,
    initramfs: &Path,
    root: &Path,
    run_dir: &Path,
    opts: &VmOptions,
    t0: Instant,
) -> Result<BootEnd> {
    let mut cmd = Command::new(&assets.qemu);
    for d in &assets.qemu_data {
        cmd.arg("-L").arg(d);
    }
    if let Some(m) = &assets.qemu_modules {
        cmd.env("QEMU_MODULE_DIR", m);
    }
    let repo = root.display().to_string();
    let run = run_dir.display().to_string();
    cmd.args([
        "-machine",
        "q35",
        "-accel",
        "tcg,thread=multi",
        "-cpu",
        "max",
    ])
    .args([
        "-m",
        &opts.mem_mib.to_string(),
        "-smp",
        &opts.smp.to_string(),
    ])
    .args([
        "-nodefaults",
        "-no-user-config",
        "-display",
        "none",
        "-vga",
        "none",
    ])
    .args(["-serial", "stdio", "-monitor", "none", "-no-reboot"])
    .arg("-kernel")
    .arg(&assets.kernel)
    .arg("-initrd")
    .arg(initramfs)
    .args([
        "-append",
        &format!("console=ttyS0 quiet loglevel=3 panic=-1 XTASK_REPO={repo} XTASK_RUN={run}"),
    ])
    .args([
        "-virtfs",
        "local,path=/,mount_tag=hostroot,security_model=none,readonly=on,multidevs=remap",
    ])
    .args([
        "-virtfs",
        &format!("local,path={repo},mount_tag=repo,security_model=none,multidevs=remap"),
    ]);
    if opts.can > 0 {
        cmd.args(["-object", "can-bus,id=canbus0"]);
        for _ in 0..opts.can {
            cmd.args(["-device", "kvaser_pci,canbus=canbus0"]);
        }
    }
    if repo.contains(',') || run.contains(' ') {
        return Err(format!(
            "the repository path `{repo}` must not contain commas or spaces (QEMU option syntax)"
        ));
    }
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| {
            format!(
                "{}: {e} (a QEMU unpacked without its libraries needs `apt-get install qemu-system-x86`)",
                assets.qemu.display()
            )
        })?;
    let stdout = child.stdout.take().ok_or("qemu has no stdout")?;
    let (tx, rx) = mpsc::channel::<String>();
    let reader = std::thread::spawn(move || {
        let mut r = BufReader::new(stdout);
        let mut buf = Vec::new();
        loop {
            buf.clear();
            match r.read_until(b'\n', &mut buf) {
                Ok(0) | Err(_) => break,
                Ok(_) => {
                    let line = String::from_utf8_lossy(&buf).replace('\r', "");
                    if tx.send(line).is_err() {
                        break;
                    }
                }
            }
        }
        let mut rest = Vec::new();
        let _ = r.read_to_end(&mut rest);
    });
    let deadline = t0 + opts.timeout;
    let mut boot_log = String::new();
    let mut inside = false;
    let mut seen_end = false;
    let stdout = std::io::stdout();
    let end = loop {
        let now = Instant::now();
        if now >= deadline {
            let _ = child.kill();
            break BootEnd::TimedOut;
        }
        match rx.recv_timeout(deadline - now) {
            Ok(line) => {
                let trimmed = line.trim_end();
                if trimmed.ends_with(BEGIN) {
                    inside = true;
                    eprintln!(
                        "xtask vm: guest up after {:.1} s",
                        t0.elapsed().as_secs_f64()
                    );
                } else if trimmed.ends_with(END) {
                    inside = false;
                    seen_end = true;
                } else if inside {
                    let mut out = stdout.lock();
                    let _ = out.write_all(line.as_bytes());
                    let _ = out.flush();
                } else if opts.verbose {
                    eprint!("{line}");
                } else {
                    boot_log += &line;
                }
            }
            Err(mpsc::RecvTimeoutError::Timeout) => continue,
            Err(mpsc::RecvTimeoutError::Disconnected) => break BootEnd::Exited,
        }
    };
    let _ = child.wait();
    let _ = reader.join();
    if !seen_end && !opts.verbose {
        eprint!("{boot_log}");
    }
    Ok(end)
}
