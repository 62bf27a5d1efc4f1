//! Progress reports, cancellation and per-stage wall-clock seconds of a conversion, and the
//! parallel loop over charts that reports as it goes.
//!
//! Space: none.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::error::{GeomtexError, Result};

/// Progress: called with a stage name and its completed fraction in [0, 1]; returning false
/// cancels the conversion. May be called from worker threads.
pub type Progress<'a> = &'a (dyn Fn(&str, f64) -> bool + Sync);

/// Reports `fraction` of `stage`; Cancelled if the callback says stop.
pub fn report(progress: Progress, stage: &str, fraction: f64) -> Result<()> {
    if progress(stage, fraction) {
        Ok(())
    } else {
        Err(GeomtexError::Cancelled(stage.into()))
    }
}

/// The stages of one conversion as they run: each is reported when it begins and timed until
/// it ends.
pub struct Stages<'a> {
    pub progress: Progress<'a>,
    started: Instant,
    lap_start: Instant,
    /// Seconds each finished stage took, in order.
    pub seconds: Vec<(String, f64)>,
}

impl<'a> Stages<'a> {
    pub fn new(progress: Progress<'a>) -> Stages<'a> {
        let now = Instant::now();
        Stages {
            progress,
            started: now,
            lap_start: now,
            seconds: Vec::new(),
        }
    }

    /// Reports that `stage` begins.
    pub fn begin(&self, stage: &str) -> Result<()> {
        report(self.progress, stage, 0.0)
    }

    /// Records the seconds since the previous stage ended as `stage`'s.
    pub fn end(&mut self, stage: &str) {
        let now = Instant::now();
        self.seconds
            .push((stage.into(), (now - self.lap_start).as_secs_f64()));
        self.lap_start = now;
    }

    /// Every stage's seconds and the total.
    pub fn into_seconds(mut self) -> Vec<(String, f64)> {
        self.seconds
            .push(("total".into(), self.started.elapsed().as_secs_f64()));
        self.seconds
    }
}

/// `work` on every item in parallel, reporting progress as `stage` and stopping early when the
/// callback cancels.
pub fn each_chart<J: Sync, T: Send>(
    items: &[J],
    progress: Progress,
    stage: &str,
    work: impl Fn(&J) -> T + Sync,
) -> Result<Vec<T>> {
    let done = AtomicUsize::new(0);
    let cancelled = AtomicBool::new(false);
    let out: Vec<Option<T>> = items
        .par_iter()
        .map(|item| {
            if cancelled.load(Ordering::Relaxed) {
                return None;
            }
            let t = work(item);
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            if k.is_multiple_of(16) && !progress(stage, k as f64 / items.len() as f64) {
                cancelled.store(true, Ordering::Relaxed);
            }
            Some(t)
        })
        .collect();
    if cancelled.load(Ordering::Relaxed) {
        return Err(GeomtexError::Cancelled(stage.into()));
    }
    Ok(out.into_iter().flatten().collect())
}
