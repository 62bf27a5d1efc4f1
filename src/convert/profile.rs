//! Optional per-phase timers inside a conversion's stages (`GEOMTEX_PROFILE=1`): how often each
//! inner phase ran and the thread-seconds it took, summed over worker threads and printed to
//! stderr when a conversion ends. The stage seconds in `stats["seconds"]` say which stage is
//! slow; these say which part of it, without a profiler on the loaded CI machines.
//!
//! Space: none.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;
use std::time::Instant;

/// The inner phases timed.
#[derive(Clone, Copy, Debug)]
pub enum Phase {
    Samples,
    Rasterize,
    Gaps,
    PastTheMesh,
    Quantile,
    Centres,
    Margins,
    Corners,
    OutlineDistance,
    IntoMaps,
}

const PHASES: [&str; 10] = [
    "samples",
    "rasterize",
    "gaps",
    "past_the_mesh",
    "quantile",
    "centres",
    "margins",
    "corners",
    "outline_distance",
    "into_maps",
];

static NANOS: [AtomicU64; 10] = [const { AtomicU64::new(0) }; 10];
static COUNTS: [AtomicU64; 10] = [const { AtomicU64::new(0) }; 10];

fn enabled() -> bool {
    static ON: OnceLock<bool> = OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("GEOMTEX_PROFILE").is_some_and(|v| v != "0"))
}

/// `work`, timed as `phase` when profiling is on.
pub fn timed<T>(phase: Phase, work: impl FnOnce() -> T) -> T {
    if !enabled() {
        return work();
    }
    let start = Instant::now();
    let out = work();
    let k = phase as usize;
    NANOS[k].fetch_add(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
    COUNTS[k].fetch_add(1, Ordering::Relaxed);
    out
}

/// Prints and clears the totals when profiling is on.
pub fn report() {
    if !enabled() {
        return;
    }
    for (k, name) in PHASES.iter().enumerate() {
        let nanos = NANOS[k].swap(0, Ordering::Relaxed);
        let count = COUNTS[k].swap(0, Ordering::Relaxed);
        eprintln!(
            "geomtex profile: {name:14} {count:9} runs {:9.3} thread-s",
            nanos as f64 * 1e-9
        );
    }
}
