//! Test helpers: a [`Progress`] that records every stage and update.

use std::sync::Mutex;

use isoray_job::Progress;

/// A stage's name and the (done, total) updates heard during it, in order.
pub(crate) type Stage = (String, Vec<(u64, u64)>);

/// Every stage begun, with the updates heard during it, in order.
#[derive(Debug, Default)]
pub(crate) struct Recorder(Mutex<Vec<Stage>>);

impl Progress for Recorder {
    fn update(&self, done: u64, total: u64) {
        let mut stages = self.0.lock().unwrap();
        if stages.is_empty() {
            stages.push((String::new(), Vec::new()));
        }
        stages.last_mut().expect("nonempty").1.push((done, total));
    }

    fn stage(&self, name: &str) {
        self.0.lock().unwrap().push((name.to_string(), Vec::new()));
    }
}

impl Recorder {
    /// The stages heard so far.
    pub(crate) fn stages(&self) -> Vec<Stage> {
        self.0.lock().unwrap().clone()
    }

    /// Asserts that every update came within a named stage, that each stage
    /// heard at least one update, that `done` never decreased within a
    /// stage and never exceeded `total`, and that every stage for which
    /// `complete(name)` holds ended with `done == total`. Returns the stages.
    pub(crate) fn check(&self, complete: impl Fn(&str) -> bool) -> Vec<Stage> {
        let stages = self.stages();
        assert!(!stages.is_empty(), "no progress reported");
        for (name, updates) in &stages {
            assert!(!name.is_empty(), "an update outside any stage");
            assert!(!updates.is_empty(), "stage `{name}` heard no update");
            for w in updates.windows(2) {
                assert!(w[0].0 <= w[1].0, "stage `{name}`: done went back: {updates:?}");
            }
            for &(d, t) in updates {
                assert!(d <= t, "stage `{name}`: {d} done of {t}");
            }
            if complete(name) {
                let (d, t) = *updates.last().expect("nonempty");
                assert_eq!(d, t, "stage `{name}` ended at {d} of {t}");
            }
        }
        stages
    }
}
