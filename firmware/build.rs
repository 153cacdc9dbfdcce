//! Board-image build steps, applied only when building for a thumb target:
//! linker scripts (`link.x` from cortex-m-rt, `defmt.x`, the workspace's `memory.x`) and the
//! replay file compiled into the image.
//!
//! `RLG_MODEL_TABLE` (any target) names a Rust source file defining `pub const MODEL:
//! compensator_core::ModelTable<N, D>` that replaces the committed `src/model_table.rs`: how
//! the budget measurements build images with synthetic tables of other sizes. Unset in every
//! normal build. A relative path is taken from the workspace root.
//!
//! `RLG_REPLAY_BIN` names the replay file (format: `src/replay/format.rs`); a relative path is
//! taken from the workspace root. Default: `firmware/replay/default.bin`.

use std::path::PathBuf;
use std::{env, fs};

#[allow(dead_code)] // only the parser is needed here
#[path = "src/replay/format.rs"]
mod format;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=RLG_REPLAY_BIN");
    println!("cargo:rerun-if-env-changed=RLG_MODEL_TABLE");
    println!("cargo::rustc-check-cfg=cfg(rlg_model_table_file)");
    if let Some(p) = env::var_os("RLG_MODEL_TABLE").filter(|p| !p.is_empty()) {
        let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
        let table = manifest.parent().expect("workspace").join(p);
        println!("cargo:rerun-if-changed={}", table.display());
        let out = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));
        let text = fs::read_to_string(&table)
            .unwrap_or_else(|e| panic!("RLG_MODEL_TABLE: cannot read {}: {e}", table.display()));
        fs::write(out.join("model_table.rs"), text).expect("OUT_DIR is writable");
        println!("cargo:rustc-cfg=rlg_model_table_file");
    }
    let target = env::var("TARGET").unwrap_or_default();
    if !target.starts_with("thumb") {
        return; // host build: the library and its tests need neither
    }
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let root = manifest
        .parent()
        .expect("firmware/ sits in the workspace")
        .to_path_buf();
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));

    let memory = root.join("memory.x");
    println!("cargo:rerun-if-changed={}", memory.display());
    fs::copy(&memory, out.join("memory.x"))
        .unwrap_or_else(|e| panic!("cannot copy {}: {e}", memory.display()));
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");

    let replay = match env::var_os("RLG_REPLAY_BIN") {
        Some(p) if !p.is_empty() => root.join(p), // join keeps an absolute path as is
        _ => manifest.join("replay").join("default.bin"),
    };
    println!("cargo:rerun-if-changed={}", replay.display());
    let bytes = fs::read(&replay)
        .unwrap_or_else(|e| panic!("RLG_REPLAY_BIN: cannot read {}: {e}", replay.display()));
    if let Err(e) = format::ReplayData::parse(&bytes) {
        panic!(
            "RLG_REPLAY_BIN: {} is not a replay file: {e}",
            replay.display()
        );
    }
    fs::write(out.join("replay.bin"), &bytes).expect("OUT_DIR is writable");
}
