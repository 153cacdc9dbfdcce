//! The firmware's 1 Hz path has no reachable panic under the board image's profile
//! (`firmware`: fat LTO, opt-level s, the profile `cargo fw-build` uses):
//! `firmware/src/bin/no_panic.rs`
//! runs it with a panic handler that calls an undefined function, so the image links only if
//! the optimiser removed every panic. The negative control (a deliberate out-of-bounds index)
//! must fail the link with that symbol, so the check is shown able to fail.

use std::process::{Command, Output};

use tests::firmware::{workspace_root, TARGET};

fn build(control: bool) -> Output {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(workspace_root())
        .args([
            "build",
            "-p",
            "firmware",
            "--profile",
            "firmware",
            "--target",
        ])
        .args([TARGET, "--bin", "no-panic", "--features", "no-panic-proof"])
        .env_remove("RLG_MODEL_TABLE");
    if control {
        cmd.env("RLG_NO_PANIC_CONTROL", "1");
    } else {
        cmd.env_remove("RLG_NO_PANIC_CONTROL");
    }
    cmd.output().expect("cargo runs")
}

#[test]
fn the_one_hertz_path_links_without_a_panic_handler() {
    let out = build(false);
    assert!(
        out.status.success(),
        "a panic is reachable on the 1 Hz path (or the build failed):\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let control = build(true);
    let err = String::from_utf8_lossy(&control.stderr);
    assert!(
        !control.status.success() && err.contains("rlg_panic_is_reachable"),
        "the negative control should fail to link on the undefined symbol:\n{err}"
    );
    // Leave the normal image built last, so later builds start from it.
    assert!(build(false).status.success());
}
