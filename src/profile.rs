//! Optional per-phase timers inside a conversion's stages (`GEOMTEX_PROFILE=1`): how often each
//! inner phase ran and the thread-seconds it took, summed over worker threads and printed to
//! stderr when a conversion ends. The stage seconds in `stats["seconds"]` say which stage is
//! slow; these say which part of it, without a profiler on the loaded CI machines. Crate-level:
//! the mesh's geometry and the renderer's shadow pass mark their memory and time too.
//!
//! With profiling on, each stage's end also prints the process's resident memory (VmRSS) and
//! its peak over the stage (VmHWM, reset through /proc/self/clear_refs when the stage ends, so
//! each line is that stage's own peak; the largest is printed with the totals). Linux only;
//! elsewhere the memory lines are left out.
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
    Bound,
}

const PHASES: [&str; 11] = [
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
    "bound",
];

static NANOS: [AtomicU64; 11] = [const { AtomicU64::new(0) }; 11];
static COUNTS: [AtomicU64; 11] = [const { AtomicU64::new(0) }; 11];

/// Whether `GEOMTEX_PROFILE` asks for timers (read once).
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

/// Phase timers of the renderer's shadow and ray-query passes, printed to stderr (as
/// "geomtex shadow: …") when profiling is on: milliseconds since the last mark.
pub(crate) fn mark(what: std::fmt::Arguments, since: &mut std::time::Instant) {
    if enabled() {
        eprintln!(
            "geomtex shadow: {:8.2} ms {what}",
            since.elapsed().as_secs_f64() * 1e3
        );
    }
    *since = std::time::Instant::now();
}

/// Largest VmHWM a stage's line printed since the last `report`, KiB.
static PEAK_KIB: AtomicU64 = AtomicU64::new(0);

/// A field of /proc/self/status in KiB, if there is one.
fn status_kib(field: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    line[field.len()..].split_whitespace().next()?.parse().ok()
}

/// When profiling is on: prints the resident memory now and its peak since the last mark
/// (`what` names the interval that ended), then starts the next interval's peak from here.
pub fn memory(what: &str) {
    if !enabled() {
        return;
    }
    let (Some(rss), Some(hwm)) = (status_kib("VmRSS:"), status_kib("VmHWM:")) else {
        return;
    };
    PEAK_KIB.fetch_max(hwm, Ordering::Relaxed);
    eprintln!(
        "geomtex profile: memory {what:18} rss {:8.1} MB  peak {:8.1} MB",
        rss as f64 / 1024.0,
        hwm as f64 / 1024.0
    );
    // "5" resets VmHWM to VmRSS (proc(5)); without it each line shows the running maximum.
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Prints and clears the totals when profiling is on.
pub fn report() {
    if !enabled() {
        return;
    }
    let peak = PEAK_KIB.swap(0, Ordering::Relaxed);
    eprintln!(
        "geomtex profile: memory peak of the stages {:8.1} MB",
        peak as f64 / 1024.0
    );
    for (k, name) in PHASES.iter().enumerate() {
        let nanos = NANOS[k].swap(0, Ordering::Relaxed);
        let count = COUNTS[k].swap(0, Ordering::Relaxed);
        eprintln!(
            "geomtex profile: {name:14} {count:9} runs {:9.3} thread-s",
            nanos as f64 * 1e-9
        );
    }
}
