//! Cancellation of long calls: a flag the caller sets (the binding layer on Ctrl-C) and the
//! core's long loops poll, so a call stops within a fraction of a second instead of running to
//! its end. Polling is one relaxed atomic load, cheap enough for every chart, cell or ray.
//!
//! Space: none.

use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::{GeomtexError, Result};

#[derive(Debug, Default)]
pub struct Cancel(AtomicBool);

/// A token nobody sets: for callers that never cancel (tests, Rust users).
pub static NEVER: Cancel = Cancel::new();

impl Cancel {
    pub const fn new() -> Cancel {
        Cancel(AtomicBool::new(false))
    }

    /// Asks every loop polling this token to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// `Interrupted` once the token is set, naming what was running.
    pub fn check(&self, what: &str) -> Result<()> {
        if self.is_cancelled() {
            Err(GeomtexError::Interrupted(what.into()))
        } else {
            Ok(())
        }
    }
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "unknown panic".into())
}

/// `work`, with a panic inside it turned into an `Internal` error naming `what` (a bug, reported
/// instead of unwinding into the caller: the binding layer runs every heavy call through this).
pub fn catching_panics<T>(what: &str, work: impl FnOnce() -> Result<T>) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)).unwrap_or_else(|payload| {
        Err(GeomtexError::Internal(format!(
            "internal error while {what}: {}",
            panic_message(payload.as_ref())
        )))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_fails_once_cancelled() {
        let c = Cancel::new();
        assert!(c.check("x").is_ok());
        c.cancel();
        let e = c.check("filtering").unwrap_err();
        assert!(matches!(e, GeomtexError::Interrupted(_)));
        assert_eq!(e.to_string(), "interrupted while filtering");
        assert!(NEVER.check("x").is_ok());
    }

    #[test]
    fn a_panic_becomes_an_internal_error() {
        let e = catching_panics("testing", || -> Result<()> { panic!("boom {}", 7) }).unwrap_err();
        assert!(matches!(e, GeomtexError::Internal(_)));
        assert_eq!(e.to_string(), "internal error while testing: boom 7");
        let e = catching_panics("testing", || -> Result<()> { std::panic::panic_any(3u8) });
        assert!(e.unwrap_err().to_string().ends_with("unknown panic"));
        assert_eq!(catching_panics("testing", || Ok(5)).unwrap(), 5);
        // A lock held across the panic: the next user still gets it (as the renderer's does).
        let lock = std::sync::Mutex::new(1);
        let _ = catching_panics("testing", || -> Result<()> {
            let _guard = lock.lock().unwrap();
            panic!("while holding the lock")
        });
        assert_eq!(*lock.lock().unwrap_or_else(|p| p.into_inner()), 1);
    }
}
