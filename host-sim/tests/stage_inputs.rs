//! The loop's shortcuts for the time-only inputs of its RK4 stages change no result: the fault
//! effects of a sample's stage times found with one window test per rule and sample
//! (`FaultSchedule::effects_at`) are `FaultSchedule::effect`'s at every instant, to the bit, also
//! with `sin(ω t)` from a table, and a run taking Example 1's `cos t` and its stuck rule's
//! `sin t` from tables another run computed (`SharedStageTerms`, as the runs of a campaign do)
//! gives the same summary as a run computing them.

use std::sync::Arc;

use host_sim::{
    faults::{ActuatorEffect, FaultRule, FaultSchedule, SineTable, Sines},
    run::{run, RunOptions},
    scenario::{self, Setup},
    sim::SharedStageTerms,
    Error, Result,
};

/// A `[[faults.rule]]` for all agents as a scenario file writes it: actuator `l`, `kind`
/// (half gain, or stuck at `sin t`), first window at `start`, then the keys of `window`.
fn rule(l: i64, kind: &str, start: f64, window: &str) -> Result<FaultRule> {
    let effect = match kind {
        "partial" => "gain = 0.5",
        _ => "amplitude = 1.0\nomega = 1.0",
    };
    let text = format!(
        "agents = \"all\"\nactuator = {l}\nkind = \"{kind}\"\n{effect}\nstart = {start:?}\n{window}"
    );
    toml::from_str(&text).map_err(|e| Error::invalid("faults.rule", e))
}

/// Window edges inside samples are the hard case: rules start on a stage time, just before
/// and after one and at seeded random instants; they overlap, and some have no period or no
/// length.
#[test]
fn effects_over_a_sample_are_the_effects_at_each_instant() -> Result<()> {
    let seed = 0x5eed_fa17_u64;
    println!("seed {seed:#x}");
    let mut state = seed;
    let mut uniform = |lo: f64, hi: f64| {
        // xorshift64*: enough spread for window starts and periods.
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        lo + (hi - lo) * (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64
            / (1u64 << 53) as f64
    };
    let (h, substeps, samples) = (1e-3, 4u32, 3000u64);
    let dt = h / f64::from(substeps);
    let mut starts = vec![
        0.0,
        0.5,
        0.5 + dt,
        0.5 + 0.5 * dt,
        0.75 - 1e-12,
        1.0 + 1e-12,
    ];
    starts.extend((0..24).map(|_| uniform(0.0, 2.0)));
    let (mut edges, mut compared) = (0u64, 0u64);
    let mut out = [ActuatorEffect::HEALTHY; 12];
    for &start in &starts {
        let period = uniform(0.2, 0.9);
        let repeating = |share: f64| format!("period = {period:?}\nlength = {:?}", share * period);
        let rules = [
            rule(1, "partial", start, &repeating(0.5))?,
            rule(1, "partial", start + 0.1, "length = 0.3")?,
            rule(1, "stuck", start, &repeating(0.25))?,
            rule(2, "stuck", start, "")?,
            rule(2, "partial", 0.5 * start, "period = 0.4\nlength = 0.2")?,
        ];
        let s = FaultSchedule::compile(&rules, 1, 2)?;
        for k in 0..samples {
            let t = k as f64 * h;
            let mut times = [0.0; 12];
            for (j, three) in times.chunks_exact_mut(3).enumerate() {
                let t0 = t + j as f64 * dt;
                three.copy_from_slice(&[t0, t0 + 0.5 * dt, t0 + dt]);
            }
            // The stuck rules' ω = 1 from a table of the sample's times half the time (as a
            // campaign's runs take it), computed by the rule the other half.
            let tables = [SineTable::new(1.0, &times)];
            let sines = if k % 2 == 0 {
                Sines::new(&tables, 0)
            } else {
                Sines::default()
            };
            for l in 0..2 {
                s.effects_at(0, l, &times, sines, &mut out);
                let (first, last) = (s.effect(0, l, times[0]), s.effect(0, l, times[11]));
                edges += u64::from(
                    first.gain != last.gain || first.stuck.is_some() != last.stuck.is_some(),
                );
                for (e, &tt) in out.iter().zip(&times) {
                    let want = s.effect(0, l, tt);
                    assert_eq!(e.gain.to_bits(), want.gain.to_bits(), "t = {tt}, l = {l}");
                    assert_eq!(
                        e.stuck.map(f64::to_bits),
                        want.stuck.map(f64::to_bits),
                        "t = {tt}, l = {l}"
                    );
                    compared += 1;
                }
            }
        }
    }
    println!("{compared} effects compared, {edges} samples with a window edge inside");
    assert!(edges > 100, "too few window edges inside samples: {edges}");
    Ok(())
}

fn example1(sets: &[&str]) -> Result<Setup> {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    scenario::parse(include_str!("../../scenarios/example1.toml"), &sets)
}

/// Also when the table is longer than the run, or of another timing (declined).
#[test]
fn shared_stage_terms_change_no_result() -> Result<()> {
    let shared = Arc::new(SharedStageTerms::default());
    let with = RunOptions {
        stage_terms: Some(Arc::clone(&shared)),
        ..RunOptions::default()
    };
    let first = example1(&["simulation.t_end=2.0"])?;
    let alone = run(&first, &RunOptions::default())?.summary;
    assert_eq!(run(&first, &with)?.summary, alone);
    let shorter = example1(&["simulation.t_end=1.3", "faults.rule[2].start=0.8125"])?;
    let finer = example1(&["simulation.t_end=1.0", "simulation.substeps=3"])?;
    for setup in [shorter, finer] {
        let alone = run(&setup, &RunOptions::default())?.summary;
        assert_eq!(run(&setup, &with)?.summary, alone);
    }
    Ok(())
}
