//! `rlg`: the command-line front end of `host-trainer`.
use clap::Parser;

/// A failed command prints its error and each cause on its own line and exits with 1. The
/// error is the user's to fix (a file, a line, a value), so no backtrace is printed, even
/// with `RUST_BACKTRACE` set; panics, which are bugs, still print theirs.
fn main() -> std::process::ExitCode {
    quiet_on_closed_stdout();
    let line = host_trainer::cli::command_line(std::env::args());
    match host_trainer::cli::Cli::parse().run(&line) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            // An error type whose message ends with its source's (`"{path}: {source}"`)
            // already said it: printing that cause again would only repeat the line.
            let mut previous = e.to_string();
            for cause in e.chain().skip(1) {
                let text = cause.to_string().trim_end().to_string();
                if !previous.trim_end().ends_with(&text) {
                    eprintln!("  caused by: {text}");
                }
                previous = text;
            }
            std::process::ExitCode::FAILURE
        }
    }
}

/// `rlg report | head` closes stdout early; Rust ignores SIGPIPE, so the next `println!`
/// panics. Exit quietly with the shell's status for a SIGPIPE death (128 + 13) instead, as
/// a C tool would; every other panic goes to the default hook. (Restoring the signal's
/// default action would need `unsafe`, which the workspace forbids.)
fn quiet_on_closed_stdout() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.starts_with("failed printing to stdout") && msg.contains("Broken pipe") {
            std::process::exit(141);
        }
        default(info);
    }));
}
