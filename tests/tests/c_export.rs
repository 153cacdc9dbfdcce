//! The C header export and the reference C evaluator (`tests/tests/c/rlg_eval.c`), compiled
//! with the host C compiler (`cc`): its CRC equals the table's, and its f(x) agrees with the
//! f64 reference of Eq. (10) within the f32 budget (1e-5 °/h) over the trained range.
//!
//! Without a C compiler the test fails, unless `RLG_ALLOW_MISSING_TOOLS` is set.

use std::io::Write;
use std::process::{Command, Stdio};

use rlg_train::export::F32Model;
use rlg_train::export_c::c_header;

/// Agreement budget of an f32 evaluator with the f64 reference, °/h.
const BUDGET_DPH: f64 = 1e-5;

#[test]
fn c_evaluator_matches_the_f64_reference_and_the_crc() {
    if Command::new("cc").arg("--version").output().is_err()
        && tests::firmware::skip_for_missing(
            "c_evaluator_matches_the_f64_reference_and_the_crc",
            "the C compiler `cc`",
            "install one (`apt-get install gcc`)",
        )
    {
        return;
    }
    let table = tests::default_model_table();
    let model = F32Model {
        spec: table.spec,
        support: table.support.to_vec(),
        alpha_dph: table.alpha_dph.to_vec(),
    };
    assert_eq!(model.crc32(), table.crc32);
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("c_export");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("rlg_model_table.h"),
        c_header(
            &model,
            "the committed board table (firmware/src/model_table.rs)",
        )
        .unwrap(),
    )
    .unwrap();
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
        .arg(&dir)
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

    let s = table.spec;
    let mut xs = Vec::new();
    for i in 0..=60 {
        for j in 0..=60 {
            xs.push([
                s.input_lo[0] + (s.input_hi[0] - s.input_lo[0]) * i as f32 / 60.0,
                s.input_lo[1] + (s.input_hi[1] - s.input_lo[1]) * j as f32 / 60.0,
            ]);
        }
    }
    let input: String = xs
        .iter()
        .map(|x| format!("{:e} {:e}\n", x[0], x[1]))
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
    let crc: Vec<u64> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .skip(1)
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(crc, [u64::from(table.crc32); 2], "C CRC vs stored");

    let m = table.as_model();
    let mut worst = 0.0f64;
    let mut n = 0;
    for (x, line) in xs.iter().zip(lines) {
        let got: f64 = line.parse().unwrap();
        let want = tests::budgets::predict_f64(&m, &m.standardise(x));
        worst = worst.max((got - want).abs());
        n += 1;
    }
    assert_eq!(n, xs.len());
    println!("C evaluator vs f64 reference over {n} points: max {worst:.2e} °/h");
    assert!(worst <= BUDGET_DPH, "{worst:e}");
    assert!(worst > 0.0, "an f32 evaluator cannot be exact everywhere");
}
