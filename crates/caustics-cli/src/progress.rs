//! The CPU reference on the command line: a progress bar with an estimate (indicatif), and
//! Ctrl-C cancels cleanly (no output file, exit code 130).

use caustics::Scene;
use caustics_reference::reference::{Progress, ReferenceOutput, ReferenceSettings};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Exit code of a run cancelled by Ctrl-C (128 + SIGINT, as shells report it).
pub const CANCELLED_EXIT: u8 = 130;

/// A progress bar on stderr (hidden when stderr is not a terminal) for `total` steps of long
/// GPU work (benchmarks): what is running, how far, and an estimate of what is left.
pub fn steps(total: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr_with_hz(4));
    bar.set_style(
        ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} {elapsed_precise} elapsed, about {eta} left")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(what.to_string());
    bar
}

/// Render the CPU reference with a progress bar on stderr (hidden when stderr is not a
/// terminal); Ctrl-C returns [`caustics::Error::Cancelled`].
pub fn reference_render(scene: &Scene, settings: &ReferenceSettings) -> caustics::Result<ReferenceOutput> {
    let progress = Arc::new(Progress::new());
    {
        let p = progress.clone();
        // A second handler cannot be installed (only one render per process): ignore that.
        let _ = ctrlc::set_handler(move || p.cancel());
    }
    with_bar("CPU reference", &progress, || {
        caustics_reference::reference::render_with_progress(scene, settings, &progress)
    })
}

/// Run `work` on a worker thread while a bar on stderr (hidden when stderr is not a terminal),
/// labelled `label`, follows `progress`; a panic of the worker is an error naming `label`.
pub fn with_bar<T: Send>(
    label: &str,
    progress: &Progress,
    work: impl FnOnce() -> caustics::Result<T> + Send,
) -> caustics::Result<T> {
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr_with_hz(4));
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{label} {{bar:40}} {{percent:>3}}% {{elapsed_precise}} elapsed, about {{eta}} left"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let result = std::thread::scope(|s| {
        let worker = s.spawn(work);
        while !worker.is_finished() {
            let total = progress.total();
            if total > 0 {
                bar.set_length(total);
                bar.set_position(progress.done());
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        worker.join().unwrap_or_else(|_| Err(caustics::Error::Device(format!("{label}: the worker thread panicked"))))
    });
    bar.finish_and_clear();
    result
}

/// Held from the moment a GPU render starts writing its output files to the end of the process,
/// so that Ctrl-C never cuts the outputs short.
static WRITING: Mutex<()> = Mutex::new(());

/// Ctrl-C during a GPU render: a render is one long submission that cannot be cancelled
/// half-way, so the handler ends the process at once with exit code 130, before any output file
/// exists. Once [`begin_outputs`] has been called the outputs are written in full (each
/// atomically: a temporary file renamed into place) and Ctrl-C is ignored. Returns false when a
/// handler was already installed in this process (the caustic-sphere precomputation installs
/// its own, which only cancels the precomputation).
pub fn exit_on_ctrl_c() -> bool {
    ctrlc::set_handler(|| {
        // Waits for ever once the outputs are being written: the render then ends normally.
        let _writing = WRITING.lock().unwrap_or_else(|e| e.into_inner());
        eprintln!("cancelled: nothing was written");
        hard_exit(CANCELLED_EXIT);
    })
    .is_ok()
}

/// From here on Ctrl-C no longer ends the process (see [`exit_on_ctrl_c`]).
/// Calling it again does nothing.
pub fn begin_outputs() {
    static BEGUN: std::sync::Once = std::sync::Once::new();
    BEGUN.call_once(|| std::mem::forget(WRITING.lock().unwrap_or_else(|e| e.into_inner())));
}

/// End the process from the Ctrl-C handler's thread without running exit handlers (the main
/// thread and the driver's threads are busy with the GPU render; `exit` would run destructors
/// under them).
#[cfg(unix)]
#[expect(unsafe_code, reason = "libc::_exit: ends the process; no Rust invariant is involved")]
fn hard_exit(code: u8) -> ! {
    // SAFETY: `_exit` takes any status and never returns.
    unsafe { libc::_exit(code as libc::c_int) }
}

#[cfg(not(unix))]
fn hard_exit(code: u8) -> ! {
    std::process::exit(code as i32)
}
