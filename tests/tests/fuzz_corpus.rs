//! Every input the fuzzers kept (`tests/fuzz/corpus/<target>/`) and every crash they ever
//! found (`tests/fuzz/regressions/<target>/`, none so far) runs through the same checks as the
//! fuzz targets (`tests::fuzz_checks`) on every test run, without a fuzzer.

use std::path::Path;

fn replay(target: &str, check: fn(&[u8])) -> usize {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut n = 0;
    for dir in ["corpus", "regressions"] {
        let Ok(entries) = std::fs::read_dir(root.join(dir).join(target)) else {
            continue;
        };
        for e in entries {
            let path = e.expect("directory entry").path();
            let data = std::fs::read(&path).expect("corpus file reads");
            check(&data);
            n += 1;
        }
    }
    n
}

#[test]
fn kept_fuzz_inputs_still_pass() {
    for (target, check) in [
        ("recording", tests::fuzz_checks::recording as fn(&[u8])),
        ("model_file", tests::fuzz_checks::model_file),
        ("core_update", tests::fuzz_checks::core_update),
    ] {
        let n = replay(target, check);
        println!("{target}: {n} inputs replayed");
        assert!(n > 0, "no corpus for {target}");
    }
}
