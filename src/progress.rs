//! Progress reports, cancellation and per-stage wall-clock seconds of a long call (a conversion,
//! an inverse geometric texture's build, a distance function), and the parallel loop over items
//! that reports as it goes. Crate-level, so every stage reports the same way without importing
//! another.
//!
//! Space: none.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

use crate::cancel::{Cancel, NEVER};
use crate::error::{GeomtexError, Result};

/// Progress of one long call: `callback(stage, fraction)` with the completed fraction in
/// [0, 1] (returning false cancels; may be called from worker threads), and the caller's cancel
/// token, which long loops poll far more often than they report.
#[derive(Clone, Copy)]
pub struct Progress<'a> {
    pub callback: &'a (dyn Fn(&str, f64) -> bool + Sync),
    pub cancel: &'a Cancel,
}

fn always(_: &str, _: f64) -> bool {
    true
}

impl<'a> Progress<'a> {
    pub fn new(callback: &'a (dyn Fn(&str, f64) -> bool + Sync), cancel: &'a Cancel) -> Self {
        Progress { callback, cancel }
    }

    /// No reports and no cancellation.
    pub fn silent() -> Progress<'static> {
        Progress {
            callback: &always,
            cancel: &NEVER,
        }
    }

    /// Interrupted if the token is set.
    pub fn check(&self, stage: &str) -> Result<()> {
        self.cancel.check(&format!("converting (stage '{stage}')"))
    }

    /// Reports `fraction` of `stage`; Cancelled if the callback says stop, Interrupted if the
    /// token is set.
    pub fn report(&self, stage: &str, fraction: f64) -> Result<()> {
        self.check(stage)?;
        if (self.callback)(stage, fraction) {
            Ok(())
        } else {
            Err(GeomtexError::Cancelled(stage.into()))
        }
    }
}

/// The stages of one long call as they run: each is reported when it begins and timed until
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
        crate::profile::memory("before");
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
        self.progress.report(stage, 0.0)
    }

    /// Records the seconds since the previous stage ended as `stage`'s.
    pub fn end(&mut self, stage: &str) {
        let now = Instant::now();
        self.seconds
            .push((stage.into(), (now - self.lap_start).as_secs_f64()));
        self.lap_start = now;
        crate::profile::memory(stage);
    }

    /// Every stage's seconds and the total.
    pub fn into_seconds(mut self) -> Vec<(String, f64)> {
        self.seconds
            .push(("total".into(), self.started.elapsed().as_secs_f64()));
        self.seconds
    }
}

/// Items finished by many threads, reported every `every` of them in order. Each report is made
/// under one lock and says the next multiple of `every`, so the caller's bar never moves back
/// (a thread that counted 8 could report after one that counted 16 had: the bar went from 0.94
/// back to 0.47 when most of a hybrid conversion's charts were no work at all).
pub struct Finished<'a> {
    progress: Progress<'a>,
    stage: &'a str,
    total: usize,
    every: usize,
    done: AtomicUsize,
    reported: Mutex<usize>,
}

impl<'a> Finished<'a> {
    pub fn new(progress: Progress<'a>, stage: &'a str, total: usize, every: usize) -> Self {
        Finished {
            progress,
            stage,
            total: total.max(1),
            every: every.max(1),
            done: AtomicUsize::new(0),
            reported: Mutex::new(0),
        }
    }

    /// Counts one item, reporting when a multiple of `every` is reached; Cancelled if the
    /// callback says stop, Interrupted if the token is set.
    pub fn one(&self) -> Result<()> {
        let k = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if !k.is_multiple_of(self.every) {
            return Ok(());
        }
        let mut reported = self.reported.lock().unwrap_or_else(|p| p.into_inner());
        *reported += self.every;
        self.progress
            .report(self.stage, *reported as f64 / self.total as f64)
    }
}

/// `work` on every item in parallel, reporting progress as `stage` and stopping early when the
/// callback cancels or the token is set (polled before every item).
pub fn each_chart<J: Sync, T: Send>(
    items: &[J],
    progress: Progress,
    stage: &str,
    work: impl Fn(&J) -> T + Sync,
) -> Result<Vec<T>> {
    let finished = Finished::new(progress, stage, items.len(), 16);
    let cancelled = AtomicBool::new(false);
    let out: Vec<Option<T>> = items
        .par_iter()
        .map(|item| {
            if cancelled.load(Ordering::Relaxed) || progress.cancel.is_cancelled() {
                return None;
            }
            let t = work(item);
            if let Err(GeomtexError::Cancelled(_)) = finished.one() {
                cancelled.store(true, Ordering::Relaxed);
            }
            Some(t)
        })
        .collect();
    progress.check(stage)?;
    if cancelled.load(Ordering::Relaxed) {
        return Err(GeomtexError::Cancelled(stage.into()));
    }
    Ok(out.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_from_many_threads_never_move_back() {
        // Items that are no work at all (a hybrid set's charts kept as triangles): the race
        // between counting and reporting is at its widest.
        let seen = Mutex::new(Vec::new());
        let callback = |_: &str, f: f64| {
            seen.lock().unwrap().push(f);
            true
        };
        let items: Vec<u32> = (0..4096).collect();
        for _ in 0..20 {
            seen.lock().unwrap().clear();
            each_chart(&items, Progress::new(&callback, &NEVER), "raster", |_| ()).unwrap();
            let seen = seen.lock().unwrap();
            assert_eq!(seen.len(), 4096 / 16);
            assert!(seen.windows(2).all(|w| w[0] < w[1]), "{seen:?}");
            assert_eq!(seen.last(), Some(&1.0));
        }
    }
}
