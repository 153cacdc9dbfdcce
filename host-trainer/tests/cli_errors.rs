//! A bad input file makes `rlg` exit with status 1 and say what is wrong and where, on
//! standard error, without a backtrace (even with `RUST_BACKTRACE` set) and without writing
//! the output file.

use std::path::Path;
use std::process::Command;

fn rlg(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rlg"))
        .args(args)
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("run rlg");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_files_give_a_located_error_and_no_output() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli_errors");
    std::fs::create_dir_all(&dir).unwrap();
    let rec = dir.join("bad.csv");
    std::fs::write(&rec, "time_s,temp_c,rate_dph\n0,20,-7.1\n1,abc,-7.1\n").unwrap();
    let (code, err) = rlg(&["diagnose", "--recording", rec.to_str().unwrap()]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(
        err.contains("bad.csv:3:2") && err.contains("expected a number"),
        "{err}"
    );
    assert!(
        !err.contains("backtrace") && !err.contains("panicked"),
        "{err}"
    );

    let scenario = dir.join("bad.toml");
    std::fs::write(&scenario, "name = \"x\"\nduration_s = \"abc\"\n").unwrap();
    let out = dir.join("never.csv");
    let (code, err) = rlg(&[
        "simulate",
        "--scenario",
        scenario.to_str().unwrap(),
        "--seed",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("bad.toml") && err.contains("line 2, column 14"),
        "{err}"
    );
    assert!(err.contains("caused by: "), "{err}");
    assert!(!err.contains("backtrace"), "{err}");
    assert!(!out.exists(), "no output file on error");
}

/// An impossible significance level, too few bootstrap replicates for it, or an unknown
/// benchmark subset are refused before any file is read, with the reason.
#[test]
fn bad_alpha_or_bootstrap_is_refused() {
    let (code, err) = rlg(&["diagnose", "--recording", "absent.csv", "--alpha", "1.5"]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("--alpha must lie strictly between 0 and 1, got 1.5"),
        "{err}"
    );
    let (code, err) = rlg(&[
        "diagnose",
        "--recording",
        "absent.csv",
        "--alpha",
        "0.01",
        "--bootstrap",
        "50",
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("needs at least 100 replicates"), "{err}");
    let (code, err) = rlg(&["benchmark-diagnose", "--out", "never", "--alpha", "0"]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("--alpha must lie strictly between 0 and 1"),
        "{err}"
    );
    assert!(!Path::new("never").exists());
    // A subset naming a term the benchmark does not know is refused, with the known names.
    let (code, err) = rlg(&[
        "benchmark-diagnose",
        "--out",
        "never",
        "--only",
        "aging,wobble",
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("--only: unknown term `wobble`") && err.contains("temp_quantization"),
        "{err}"
    );
    assert!(!Path::new("never").exists());
}
