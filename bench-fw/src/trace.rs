//! The benchmark's agent and its replayed inputs: agent 4 of Example 1 (or of the `n3` variant),
//! the trace the xtask records from a host run and embeds at build time.

use controller_core::Link;

/// State order `n`.
#[cfg(not(feature = "n3"))]
pub(crate) const N: usize = 2;
/// State order `n`.
#[cfg(feature = "n3")]
pub(crate) const N: usize = 3;
/// Actuators `m` (= `n` in the benchmark variants).
pub(crate) const M: usize = N;
/// Neighbours (agent 4 of the examples hears agents 1 and 3).
pub(crate) const K: usize = 2;
/// One record of the trace: `x_1..x_n`, `y` of the two neighbours, `y_d`.
pub(crate) const FIELDS: usize = N + K + 1;

/// The replayed inputs, little-endian `f32` records of [`FIELDS`] values, written by the xtask.
pub(crate) static TRACE: &[u8] = include_bytes!(env!("BENCH_TRACE_FILE"));

/// Record `k` of the trace: own state, the two neighbours' `y`, the leader's `y_d`.
pub(crate) fn record(k: usize) -> ([f32; N], [Link; K], Link) {
    let mut v = [0.0f32; FIELDS];
    let base = k * FIELDS * 4;
    for (i, slot) in v.iter_mut().enumerate() {
        let o = base + 4 * i;
        *slot = f32::from_le_bytes([TRACE[o], TRACE[o + 1], TRACE[o + 2], TRACE[o + 3]]);
    }
    let mut x = [0.0; N];
    x.copy_from_slice(&v[..N]);
    let neighbours = [Link::Fresh(v[N]), Link::Fresh(v[N + 1])];
    (x, neighbours, Link::Fresh(v[N + 2]))
}
