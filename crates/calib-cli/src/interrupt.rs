//! Ctrl-C (SIGINT), SIGTERM and SIGHUP: the temporary files of the writes in progress
//! (`.NAME.tmp-PID` beside each output) are removed before the process exits with 128 + the
//! signal (130, 143, 129), as a shell reports a process the signal ended. Every previous output
//! file stays as it was, or was replaced whole before the signal. SIGKILL cannot be caught:
//! a killed run's `.NAME.tmp-PID` files are incomplete copies, safe to delete.

use std::sync::atomic::{AtomicI32, Ordering};

/// The signal being handled, 0 before one arrives.
static RECEIVED: AtomicI32 = AtomicI32::new(0);

/// True once a signal arrived: the process is about to exit, and a write that failed because of
/// it is no failure to report.
pub fn received() -> bool {
    RECEIVED.load(Ordering::SeqCst) != 0
}

/// Starts the thread that handles the signals. A signal the process was started with ignored
/// (SIGINT and SIGQUIT of a shell script's background job, SIGHUP under nohup) stays ignored.
#[cfg(unix)]
pub fn install() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let wanted: Vec<i32> = [SIGINT, SIGTERM, SIGHUP]
        .into_iter()
        .filter(|&s| !ignored(s))
        .collect();
    if wanted.is_empty() {
        return;
    }
    // The handlers are installed by the thread that serves them, and the command starts once
    // they are: without the thread (it could not be started), a signal ends the process as
    // before.
    let (ready, installed) = std::sync::mpsc::sync_channel(1);
    let spawned = std::thread::Builder::new()
        .name("calib-signals".into())
        .spawn(move || {
            let signals = signal_hook::iterator::Signals::new(&wanted);
            let _ = ready.send(());
            let Ok(mut signals) = signals else {
                return;
            };
            if let Some(signal) = signals.forever().next() {
                RECEIVED.store(signal, Ordering::SeqCst);
                calib_core::io::remove_temporary_files();
                std::process::exit(128 + signal);
            }
        });
    if spawned.is_ok() {
        let _ = installed.recv();
    }
}

#[cfg(not(unix))]
pub fn install() {}

/// True if `signal` is ignored (`SIG_IGN`) in this process.
#[cfg(unix)]
fn ignored(signal: i32) -> bool {
    // SAFETY: sigaction with a null new action only reads the current one into `old`, a plain
    // C struct for which all-zero bytes are a valid value.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        libc::sigaction(signal, std::ptr::null(), &mut old) == 0
            && old.sa_sigaction == libc::SIG_IGN
    }
}

/// Called when a command failed: if a signal is being handled, the failure is its doing (a
/// write refused once the temporary files were removed); the handling thread exits the process,
/// so this waits for it instead of reporting the failure.
pub fn wait_if_stopping() {
    if received() {
        loop {
            std::thread::park();
        }
    }
}
