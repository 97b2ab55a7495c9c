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
/// The fields of a record as embedded: all of them for the step.
#[cfg(not(feature = "node"))]
pub(crate) const STORED: usize = FIELDS;
/// The fields of a record as embedded: the node variant's trace (written by `build.rs`) drops
/// `y_d`, which agent 4 (not pinned) never reads, so that the whole trace and the node with its
/// CANopen device fit the micro:bit's 256 KiB of flash.
#[cfg(feature = "node")]
pub(crate) const STORED: usize = N + K;

/// The replayed inputs, little-endian `f32` records of [`STORED`] values, written by the xtask.
pub(crate) static TRACE: &[u8] = include_bytes!(env!("BENCH_TRACE_FILE"));

/// Record `k` of the trace: own state, the two neighbours' `y`, the leader's `y_d`
/// (`Link::Missing` when the embedded trace has none).
pub(crate) fn record(k: usize) -> ([f32; N], [Link; K], Link) {
    let mut v = [0.0f32; FIELDS];
    let base = k * STORED * 4;
    for (i, slot) in v.iter_mut().enumerate().take(STORED) {
        let o = base + 4 * i;
        *slot = f32::from_le_bytes([TRACE[o], TRACE[o + 1], TRACE[o + 2], TRACE[o + 3]]);
    }
    let mut x = [0.0; N];
    x.copy_from_slice(&v[..N]);
    let neighbours = [Link::Fresh(v[N]), Link::Fresh(v[N + 1])];
    let leader = if STORED > N + K {
        Link::Fresh(v[N + K])
    } else {
        Link::Missing
    };
    (x, neighbours, leader)
}
