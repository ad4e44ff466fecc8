//! # isoray-job
//!
//! Job control shared by every long operation in isoray — scene loading and
//! surface analysis, Gröbner bases and implicitization, meshing, the ray
//! tracer and the raster pipeline: one [`CancelToken`] to ask work to stop,
//! one [`Cancelled`] error to say it did, and one [`Progress`] trait to
//! report how far it got; and [`file`], the one way results are written
//! (whole or not at all).
//!
//! ```
//! use isoray_job::{CancelToken, Cancelled, Counter, Progress};
//!
//! fn work(cancel: &CancelToken, progress: &dyn Progress) -> Result<u64, Cancelled> {
//!     let mut sum = 0;
//!     for i in 0..1000u64 {
//!         cancel.check()?;
//!         sum += i;
//!         progress.update(i + 1, 1000);
//!     }
//!     Ok(sum)
//! }
//!
//! let counter = Counter::default();
//! assert_eq!(work(&CancelToken::new(), &counter), Ok(499_500));
//! assert_eq!(counter.done(), 1000);
//! let stop = CancelToken::new();
//! stop.cancel();
//! assert_eq!(work(&stop, &counter), Err(Cancelled));
//! ```
//!
//! Work checks its token at points that come at least every few
//! milliseconds (per tile, per batch of rays, per reduction step), so a
//! cancellation takes effect well within 0.2 s.

pub mod file;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

/// A shared flag that asks work to stop. Clones share the flag; a token
/// once cancelled stays cancelled.
#[derive(Debug, Clone, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    /// A token that is not cancelled.
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks every holder of the token to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// True once [`CancelToken::cancel`] was called on any clone.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// `Err(Cancelled)` once the token is cancelled.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }

    /// The underlying flag, for code that polls an `AtomicBool`.
    pub fn flag(&self) -> &AtomicBool {
        &self.0
    }
}

/// Two tokens are equal when they share one flag (one is a clone of the other).
impl PartialEq for CancelToken {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Eq for CancelToken {}

/// The error of work stopped by its [`CancelToken`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("cancelled")]
pub struct Cancelled;

/// Receives the progress of a job. Called from worker threads.
pub trait Progress: Sync {
    /// `done` of `total` units of the current stage are finished.
    fn update(&self, done: u64, total: u64);
    /// A new stage begins (for jobs with several).
    fn stage(&self, _name: &str) {}
}

/// Ignores progress.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn update(&self, _done: u64, _total: u64) {}
}

/// Remembers the latest progress, for a thread that shows it.
#[derive(Debug, Default)]
pub struct Counter {
    done: AtomicU64,
    total: AtomicU64,
}

impl Counter {
    /// Units done.
    pub fn done(&self) -> u64 {
        self.done.load(Ordering::Relaxed)
    }
    /// Units in all.
    pub fn total(&self) -> u64 {
        self.total.load(Ordering::Relaxed)
    }
}

impl Progress for Counter {
    fn update(&self, done: u64, total: u64) {
        self.total.store(total, Ordering::Relaxed);
        self.done.store(done, Ordering::Relaxed);
    }
}

impl<F: Fn(u64, u64) + Sync> Progress for F {
    fn update(&self, done: u64, total: u64) {
        self(done, total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clones_share_the_flag() {
        let a = CancelToken::new();
        let b = a.clone();
        assert!(a.check().is_ok());
        b.cancel();
        assert!(a.is_cancelled() && a.check() == Err(Cancelled));
        assert!(a.flag().load(Ordering::Relaxed));
    }

    #[test]
    fn closures_report_progress() {
        let seen = std::sync::Mutex::new(Vec::new());
        let p = |d: u64, t: u64| seen.lock().unwrap().push((d, t));
        p.update(1, 2);
        p.stage("ignored");
        assert_eq!(*seen.lock().unwrap(), vec![(1, 2)]);
    }
}
