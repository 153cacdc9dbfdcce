//! The layering of the host crates, from the workspace's own manifests: the product (recording
//! I/O, physics, training, evaluation) never depends on the lab (simulator, diagnosis, close
//! loop, reproduction, benchmarks), and the board crate on no host crate. The compiler then
//! holds the imports to it.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

const PRODUCT: [&str; 5] = [
    "rlg-io",
    "rlg-physics",
    "rlg-train",
    "rlg-eval",
    "rlg-calibrate",
];
const LAB: [&str; 5] = [
    "rlg-simulate",
    "rlg-diagnose",
    "rlg-closeloop",
    "rlg-repro",
    "rlg-benchmarks",
];

/// Every workspace package's normal (non-dev) dependencies on other workspace packages.
fn workspace_dependencies() -> BTreeMap<String, BTreeSet<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("metadata is JSON");
    let packages = v["packages"].as_array().expect("packages");
    let names: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    packages
        .iter()
        .map(|p| {
            let deps = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|d| d["kind"].is_null())
                .map(|d| d["name"].as_str().unwrap().to_string())
                .filter(|n| names.contains(n))
                .collect();
            (p["name"].as_str().unwrap().to_string(), deps)
        })
        .collect()
}

/// The transitive closure of `pkg`'s workspace dependencies.
fn closure(deps: &BTreeMap<String, BTreeSet<String>>, pkg: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut todo = vec![pkg.to_string()];
    while let Some(p) = todo.pop() {
        for d in deps.get(&p).into_iter().flatten() {
            if seen.insert(d.clone()) {
                todo.push(d.clone());
            }
        }
    }
    seen
}

#[test]
fn the_product_never_depends_on_the_lab() {
    let deps = workspace_dependencies();
    for p in PRODUCT {
        assert!(deps.contains_key(p), "{p} is not a workspace package");
        let reach = closure(&deps, p);
        let bad: Vec<&String> = reach.iter().filter(|d| LAB.contains(&d.as_str())).collect();
        assert!(bad.is_empty(), "{p} depends on the lab: {bad:?}");
    }
    // The board crate depends on no workspace crate. The product's cross-crate tests reach
    // the lab only for the main job's simulated dynamic test, so an edit in the diagnosis, the
    // close loop or a benchmark does not rebuild them.
    assert!(deps["compensator-core"].is_empty());
    let lab_in_tests: Vec<&str> = LAB
        .into_iter()
        .filter(|l| closure(&deps, "tests").contains(*l))
        .collect();
    assert_eq!(lab_in_tests, ["rlg-simulate", "rlg-repro"]);
}

#[test]
fn no_dependency_cycle_between_workspace_crates() {
    let deps = workspace_dependencies();
    for p in deps.keys() {
        assert!(!closure(&deps, p).contains(p), "{p} depends on itself");
    }
}
