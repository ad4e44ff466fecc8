//! Ctrl-C for every long command: one cancellation token for the process,
//! cancelled by the first Ctrl-C. Commands check it and stop with exit code
//! 130, writing no output (files already on disk are left untouched).

use std::io::IsTerminal;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use isoray_job::CancelToken;

use crate::Failure;

/// The process's cancellation token, cancelled by Ctrl-C once
/// [`watch_ctrl_c`] was called.
pub(crate) fn cancel_token() -> CancelToken {
    static TOKEN: OnceLock<CancelToken> = OnceLock::new();
    TOKEN.get_or_init(CancelToken::new).clone()
}

/// Makes Ctrl-C cancel [`cancel_token`] instead of ending the process at
/// once. For commands that check the token (not for `eval`, which waits on
/// its input and keeps Ctrl-C's default). If no handler can be installed,
/// Ctrl-C keeps its default, which also leaves outputs untouched.
///
/// Work checks the token at least per tile, triangle, pixel, stage or
/// reduction step and stops cleanly; work that does not stop by itself in
/// time is cut short after [`GRACE`]: the process exits with code 130 then.
/// Outputs are written atomically (a temporary file renamed over the
/// target), so an existing output file is never left half-written.
pub(crate) fn watch_ctrl_c() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let token = cancel_token();
        let _ = ctrlc::set_handler(move || {
            token.cancel();
            std::thread::spawn(|| {
                std::thread::sleep(GRACE);
                eprintln!("error: cancelled (Ctrl-C)");
                std::process::exit(130);
            });
        });
    });
}

/// How long work has to stop by itself after Ctrl-C.
const GRACE: std::time::Duration = std::time::Duration::from_millis(150);

/// The failure of a cancelled command: exit code 130 (128 + SIGINT).
pub(crate) fn cancelled() -> Failure {
    Failure {
        code: 130,
        message: "cancelled (Ctrl-C): nothing was written".into(),
    }
}

/// A progress bar on stderr for a long job (a Gröbner basis, an
/// implicitization, a scene's surface analyses), driven by
/// [`isoray_job::Progress`] reports: shown only on a
/// terminal and only once the job has run for half a second; the stage is
/// its message, `done` of `total` its position.
pub(crate) struct JobBar {
    start: Instant,
    state: Mutex<(String, Option<indicatif::ProgressBar>)>,
}

impl JobBar {
    /// A bar for a job starting now, or `None` when stderr is not a terminal
    /// (the job then reports to nobody).
    pub(crate) fn for_terminal() -> Option<Arc<JobBar>> {
        std::io::stderr().is_terminal().then(|| {
            Arc::new(JobBar {
                start: Instant::now(),
                state: Mutex::new((String::new(), None)),
            })
        })
    }

    /// Removes the bar (before the command prints its result).
    pub(crate) fn finish(&self) {
        if let Ok(mut s) = self.state.lock() {
            if let Some(b) = s.1.take() {
                b.finish_and_clear();
            }
        }
    }
}

impl isoray_job::Progress for JobBar {
    fn stage(&self, name: &str) {
        let Ok(mut s) = self.state.lock() else { return };
        s.0 = name.to_string();
        if let Some(b) = &s.1 {
            // A new stage starts from nothing (its first update follows at once).
            b.set_position(0);
            b.set_message(name.to_string());
        }
    }

    fn update(&self, done: u64, total: u64) {
        let Ok(mut s) = self.state.lock() else { return };
        let elapsed = self.start.elapsed();
        if s.1.is_none() && elapsed > Duration::from_millis(500) {
            let style = indicatif::ProgressStyle::with_template("{spinner} {msg} [{bar:30}] {pos}/{len} {elapsed}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> ");
            // Built whole before its first draw; the time shown is the job's.
            let b = indicatif::ProgressBar::new(total)
                .with_position(done)
                .with_style(style)
                .with_message(s.0.clone())
                .with_elapsed(elapsed);
            b.enable_steady_tick(Duration::from_millis(100));
            s.1 = Some(b);
        }
        if let Some(b) = &s.1 {
            b.set_length(total);
            b.set_position(done);
        }
    }
}

/// The bar as the engine's progress reporter.
pub(crate) fn reporter(bar: &Option<Arc<JobBar>>) -> Option<Arc<dyn isoray_job::Progress + Send>> {
    bar.clone().map(|b| b as Arc<dyn isoray_job::Progress + Send>)
}
