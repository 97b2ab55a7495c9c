//! One hour of simulated time of Example 1 with the recurring faults (fault endurance).
//! Ignored under plain `cargo test` (it takes a while in a debug build); run it with
//! `cargo test -p controller-core --release --test soak -- --ignored --nocapture`. With
//! `SOAK_OUT=<dir>` it also writes both windows to `<dir>/soak.json` (docs/RELIABILITY.md's
//! table, `cargo xtask docs`).

mod common;

#[derive(Default, Debug)]
struct Window {
    error: f64,
    mu: f32,
    xi: f32,
    lambda: f32,
    u: f64,
}

impl Window {
    fn json(&self) -> String {
        format!(
            "{{\"error\":{:?},\"mu\":{:?},\"xi\":{:?},\"lambda\":{:?},\"u\":{:?}}}",
            self.error, self.mu, self.xi, self.lambda, self.u
        )
    }

    fn add(&mut self, s: &common::Sample) {
        self.error = self.error.max(s.max_error);
        self.u = self.u.max(s.max_abs_u);
        for e in &s.estimates {
            self.mu = self.mu.max(e.mu);
            self.xi = self.xi.max(e.xi);
            self.lambda = self.lambda.max(e.lambda);
        }
    }
}

#[test]
#[ignore]
fn one_hour_of_recurring_faults_stays_bounded() {
    let hours: f64 = std::env::var("SOAK_HOURS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1.0);
    let h = 1e-3;
    let steps = (hours * 3600.0 / h).round() as u64;
    let window = (600.0 / h) as u64;
    let mut sim = common::Example1::new(2.0, h, true, true);
    let (mut first, mut last) = (Window::default(), Window::default());
    // The first window starts after the predefined time 2 Ts = 4 s (the transient is not "first").
    let settle = (4.0 / h) as u64;
    assert!(
        steps >= settle + 2 * window,
        "SOAK_HOURS must cover two 10-minute windows"
    );
    for k in 0..steps {
        let s = sim.step();
        if (settle..settle + window).contains(&k) {
            first.add(&s);
        }
        if k >= steps - window {
            last.add(&s);
        }
    }
    println!("soak {hours} h: first 10 min after 2Ts {first:?}");
    println!("soak {hours} h: last 10 min            {last:?}");
    if let Some(dir) = std::env::var_os("SOAK_OUT") {
        let dir = std::path::PathBuf::from(dir);
        std::fs::create_dir_all(&dir).expect("SOAK_OUT is writable");
        let json = format!(
            "{{\"hours\":{hours:?},\"first\":{},\"last\":{}}}",
            first.json(),
            last.json()
        );
        std::fs::write(dir.join("soak.json"), json).expect("SOAK_OUT is writable");
    }
    // Nothing grows: the last window is no worse than the first beyond a small margin.
    assert!(
        last.error <= first.error * 1.1 + 1e-3,
        "error grew: {first:?} -> {last:?}"
    );
    for (a, b, name) in [
        (first.mu, last.mu, "mu"),
        (first.xi, last.xi, "xi"),
        (first.lambda, last.lambda, "lambda"),
    ] {
        assert!(
            b.is_finite() && b <= a * 1.1 + 1e-3,
            "{name} grew: {a} -> {b}"
        );
    }
    assert!(
        last.u <= first.u * 1.1 + 1e-3,
        "|u| grew: {} -> {}",
        first.u,
        last.u
    );
}
