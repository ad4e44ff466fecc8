//! Ctrl-C for every long command: one cancellation token for the process,
//! cancelled by the first Ctrl-C. Commands check it and stop with exit code
//! 130, writing no output (files already on disk are left untouched).

use std::sync::OnceLock;

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
/// Work checks the token at least per tile, stage or reduction step and
/// stops cleanly; a stage that does not check it often enough (building an
/// environment map) is cut short after [`GRACE`]: the process exits with
/// code 130 then. Outputs are written atomically (a temporary file renamed
/// over the target), so an existing output file is never left half-written.
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
