//! The committed default table (`firmware/src/model_table.rs`) must be what the shipped
//! pipeline makes today; regenerate with the command in its `@generated` header.
//!
//! Text outside numbers must match exactly (provenance, sizes, σ, c, command). Numbers must
//! match to 1e-5 relative: a last-bit difference of the f64 solve on another CPU (SIMD
//! paths differ) may move an f32 literal by an ulp, whereas a stale table (other data, seed,
//! σ or c) moves every coefficient by far more.

use rlg_repro::pipeline;

/// Relative tolerance on each numeric literal; f32 ulp is 6e-8 relative.
const NUMBER_TOLERANCE: f64 = 1e-5;

/// Splits source text into numeric literals and the text between them. The table's CRC is
/// a function of the numbers, so its value is not compared (an ulp would change it); the
/// board checks it against the numbers at boot, and `table_crc.rs` tests that.
fn tokens(s: &str) -> Vec<Result<f64, String>> {
    let mut out = Vec::new();
    let mut after_crc = false;
    for t in s.split(|c: char| c.is_whitespace() || ",[]();:{}".contains(c)) {
        if t.is_empty() {
            continue;
        }
        if after_crc {
            after_crc = false;
            out.push(Err("<crc32>".to_string()));
            continue;
        }
        after_crc = t == "crc32";
        out.push(t.parse::<f64>().map_err(|_| t.to_string()));
    }
    out
}

fn differences(committed: &str, fresh: &str) -> Vec<String> {
    let (a, b) = (tokens(committed), tokens(fresh));
    let mut out = Vec::new();
    if a.len() != b.len() {
        out.push(format!("token count {} vs {}", a.len(), b.len()));
    }
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        let same = match (x, y) {
            (Ok(x), Ok(y)) => (x - y).abs() <= NUMBER_TOLERANCE * x.abs().max(y.abs()).max(1e-30),
            (Err(x), Err(y)) => x == y,
            _ => false,
        };
        if !same {
            out.push(format!("token {i}: committed {x:?}, fresh {y:?}"));
        }
    }
    out
}

#[test]
fn committed_default_table_is_fresh() {
    let root = tests::firmware::workspace_root();
    let committed = std::fs::read_to_string(root.join("firmware/src/model_table.rs")).unwrap();
    let fresh = pipeline::default_table_source().unwrap();
    let diffs = differences(&committed, &fresh);
    assert!(
        diffs.is_empty(),
        "firmware/src/model_table.rs is stale; run `cargo run --release --bin {}`.\n{}",
        pipeline::DEFAULT_TABLE_COMMAND.trim_start_matches("rlg "),
        diffs
            .iter()
            .take(10)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// The comparison itself must catch a changed coefficient and a changed header.
#[test]
fn the_comparison_catches_changes() {
    let a = "// sigma = 1.0\nconst X: [f32; 2] = [0.5, -7.1];";
    assert!(differences(a, a).is_empty());
    assert!(!differences(a, &a.replace("-7.1", "-7.1001")).is_empty());
    assert!(!differences(a, &a.replace("sigma", "gamma")).is_empty());
    assert!(differences(a, &a.replace("-7.1", "-7.10000001")).is_empty());
    let b = "crc32: 0x733c0eda, x: 1.0";
    assert!(differences(b, &b.replace("733c", "0000")).is_empty());
    assert!(!differences(b, &b.replace("1.0", "2.0")).is_empty());
}
