//! Training is deterministic: the same data and options give a byte-identical table and model
//! file, whether the trainer runs on one thread or on several (rayon parallelises the kernel
//! fill, faer the factorisations), and on the mixed-precision path of large exact solves.

use rlg_repro::pipeline;
use rlg_train::model::{ModelFile, Provenance};

/// faer's parallelism is process-global: the tests of this file take turns setting it.
static GLOBAL_PARALLELISM: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    let _turn = GLOBAL_PARALLELISM
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon pool");
    let before = faer::get_global_parallelism();
    faer::set_global_parallelism(faer::Par::rayon(threads));
    let out = pool.install(f);
    faer::set_global_parallelism(before);
    out
}

/// The default table (fixed-size LS-SVM, 64 vectors) on 1 and on 2 threads, twice each.
#[test]
fn default_table_is_byte_identical_across_runs_and_thread_counts() {
    let one = on_threads(1, || pipeline::default_table_source().unwrap());
    let two = on_threads(2, || pipeline::default_table_source().unwrap());
    let again = on_threads(2, || pipeline::default_table_source().unwrap());
    assert!(one.len() > 1000, "a table, not a stub: {} bytes", one.len());
    assert_eq!(one, two, "1 thread vs 2 threads");
    assert_eq!(two, again, "two runs on 2 threads");
}

/// An exact model on 1500 samples (the mixed-precision solve) on 1 and on 2 threads.
#[test]
fn exact_model_file_is_byte_identical_across_thread_counts() {
    let n = 1500;
    let x: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let t = 10.0 + 55.0 * ((i as f64 * 0.618_034) % 1.0);
            let r = -0.02 + 0.04 * ((i as f64 * 0.414_214) % 1.0);
            vec![t, r]
        })
        .collect();
    let y: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, v)| {
            -7.1 + 1e-3 * (0.2 * v[0]).sin()
                + 0.05 * v[1]
                + 1e-4 * ((i * 7919 % 101) as f64 - 50.0) / 50.0
        })
        .collect();
    let names = vec!["temp_c".to_string(), "temp_rate_c_per_s".to_string()];
    let train = || {
        let prov = Provenance::from_bytes("synthetic.csv", b"1,2,3", "rlg train");
        ModelFile::train(&names, &x, &y, 0.67, 42.0, 60.0, 1.0, false, prov)
            .unwrap()
            .to_json()
    };
    let one = on_threads(1, train);
    let two = on_threads(2, train);
    assert!(one.len() > 10_000, "{} bytes", one.len());
    assert_eq!(one, two);
}
