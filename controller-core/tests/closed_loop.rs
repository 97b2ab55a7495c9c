//! Closed-loop check of the paper's Example 1 (LAW §8) with the minimal RK4 plant of
//! `common`: four agents, faults and quantizer on, h = 1 ms.

mod common;

/// Max |y_i − y_d| over samples with t ≥ t_from; checks on the way that every estimate stays
/// non-negative and finite and every command finite.
fn max_error_after(ts: f32, t_end: f64, t_from: f64) -> f64 {
    let mut sim = common::Example1::new(ts, 1e-3, true, true);
    let steps = (t_end / 1e-3).round() as usize;
    let mut worst: f64 = 0.0;
    for _ in 0..steps {
        let s = sim.step();
        for e in &s.estimates {
            let all = [e.mu, e.xi, e.lambda];
            assert!(
                all.iter().all(|v| v.is_finite() && *v >= 0.0),
                "t = {}: {e:?}",
                s.t
            );
        }
        assert!(s.max_abs_u.is_finite(), "t = {}", s.t);
        if s.t >= t_from {
            worst = worst.max(s.max_error);
        }
    }
    worst
}

#[test]
fn example1_tracks_after_predefined_time_with_faults_and_quantizer() {
    let e2 = max_error_after(2.0, 10.0, 4.0);
    println!("Example 1, Ts = 2: max |y_i - y_d| after 4 s = {e2:.4}");
    assert!(e2 < 0.25, "max error after 2 Ts = {e2}");
    let e1 = max_error_after(1.0, 10.0, 2.0);
    println!("Example 1, Ts = 1: max |y_i - y_d| after 2 s = {e1:.4}");
    assert!(
        e1 < e2,
        "Ts = 1 ({e1}) should track tighter than Ts = 2 ({e2})"
    );
}
