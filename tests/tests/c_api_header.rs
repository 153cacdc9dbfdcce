//! The committed C API header (`compensator-core/capi/include/rlg_compensator.h`) is what
//! cbindgen generates from the crate's Rust source today; regenerate it with
//! `RLG_BLESS=1 cargo test -p tests --test c_api_header`.

use std::path::Path;

/// The header cbindgen generates from `compensator-core/capi` with its `cbindgen.toml`.
fn generate(crate_dir: &Path) -> String {
    let config = cbindgen::Config::from_file(crate_dir.join("cbindgen.toml"))
        .expect("compensator-core/capi/cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(crate_dir.join("src/lib.rs"))
        .generate()
        .expect("cbindgen generates the header");
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).expect("UTF-8")
}

#[test]
fn committed_c_api_header_is_fresh() {
    let crate_dir = tests::firmware::workspace_root().join("compensator-core/capi");
    let path = crate_dir.join("include/rlg_compensator.h");
    let fresh = generate(&crate_dir);
    if std::env::var_os("RLG_BLESS").is_some() {
        std::fs::write(&path, &fresh).expect("write the header");
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    let first_diff = committed
        .lines()
        .zip(fresh.lines())
        .position(|(a, b)| a != b)
        .unwrap_or(committed.lines().count().min(fresh.lines().count()));
    assert!(
        committed == fresh,
        "compensator-core/capi/include/rlg_compensator.h is stale (first difference at line {}); \
         regenerate with `RLG_BLESS=1 cargo test -p tests --test c_api_header`",
        first_diff + 1
    );
    // What the header must tell a C team: each function, the status bits, units, the rate.
    for want in [
        "rlg_init(",
        "rlg_update(",
        "rlg_fixed_init(",
        "rlg_fixed_update(",
        "rlg_init_axes(",
        "rlg_update_axes(",
        "rlg_fixed_init_axes(",
        "rlg_fixed_update_axes(",
        "#define RLG_STATUS_TEMP_FAULT 4",
        "#define RLG_COMPENSATOR_SIZE",
        "#define RLG_STATE_ALIGN 8",
        "once per table period",
        "°C",
        "°/h",
        "@generated",
    ] {
        assert!(fresh.contains(want), "the header lacks {want:?}");
    }
}
