//! A board table's C header run through the reference C evaluator (`tests/c/rlg_eval.c`),
//! compiled with the host C compiler: what a C firmware would compute from it.

use std::io::Write;
use std::process::{Command, Stdio};

/// The C header of a table, compiled with `-Wall -Werror` beside the reference evaluator and
/// run on `xs`; returns its outputs (°/h), after checking its CRC line against the table's.
/// `None` only when `cc` is missing and the opt-out variable is set (otherwise that fails).
pub fn evaluate(
    header: &str,
    dir: &std::path::Path,
    xs: &[Vec<f32>],
    crc: u32,
) -> Option<Vec<f64>> {
    if Command::new("cc").arg("--version").output().is_err()
        && crate::firmware::skip_for_missing(
            "C header evaluation",
            "the C compiler `cc`",
            "install one (`apt-get install gcc`)",
        )
    {
        return None;
    }
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("rlg_model_table.h"), header).unwrap();
    let src = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/c/rlg_eval.c");
    let exe = dir.join("rlg_eval");
    let out = Command::new("cc")
        .args([
            "-std=c99",
            "-O2",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-DRLG_EVAL_MAIN",
        ])
        .arg("-I")
        .arg(dir)
        .arg("-I")
        .arg(crate::capi::include_dir())
        .arg(src)
        .arg("-o")
        .arg(&exe)
        .arg("-lm")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let input: String = xs
        .iter()
        .map(|x| {
            x.iter()
                .map(|v| format!("{v:e}"))
                .collect::<Vec<_>>()
                .join(" ")
                + "\n"
        })
        .collect();
    let mut child = Command::new(&exe)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    let crcs: Vec<u64> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .skip(1)
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(crcs, [u64::from(crc); 2], "C CRC vs the Rust table's");
    Some(lines.map(|l| l.parse().unwrap()).collect())
}
