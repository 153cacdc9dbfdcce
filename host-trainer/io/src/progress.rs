//! Progress bars on stderr for the long steps (tuning, benchmarks); indicatif hides them
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
