//! Progress bars and spinners on stderr for the long steps (reading, tuning, diagnosing,
//! benchmarks); indicatif hides them
//! when stderr is not a terminal, so logs and pipes stay clean.

use indicatif::{ProgressBar, ProgressStyle};

/// A progress bar on stderr for a step of `what`; invisible when stderr is not a terminal.
pub fn progress(what: &str) -> ProgressBar {
    let pb = ProgressBar::new(0);
    if let Ok(style) = ProgressStyle::with_template("{msg:<28} [{bar:30}] {pos}/{len} ({elapsed})")
    {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_message(what.to_string());
    pb
}

/// A spinner on stderr for a step of unknown length (reading a large file, a diagnosis), with
/// its elapsed time; invisible when stderr is not a terminal. Call `finish_and_clear` after.
pub fn spinner(what: &str) -> ProgressBar {
    let pb = ProgressBar::new_spinner();
    if let Ok(style) = ProgressStyle::with_template("{spinner} {msg} ({elapsed})") {
        pb.set_style(style);
    }
    pb.set_message(what.to_string());
    pb.enable_steady_tick(std::time::Duration::from_millis(120));
    pb
}
