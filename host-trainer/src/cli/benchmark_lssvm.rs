//! `rlg bench-scale`, `rlg bench-lssvm` and `rlg sparse-report`: the LS-SVM's scale, speed and
//! reduced models (`host-trainer/benchmarks/README.md`; figures of record in CHANGELOG.md).

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use rlg_benchmarks::lssvm as bench;
use rlg_repro::pipeline;
use rlg_repro::sparse_eval;
use rlg_train::lssvm::sparse::DEFAULT_BUDGET;

/// Arguments of `rlg bench-scale`.
#[derive(Debug, Args)]
pub struct BenchScaleArgs {
    /// Samples of the simulated 1 Hz campaign (10⁶ ≈ 11.6 days).
    #[arg(long, default_value_t = 1_000_000)]
    pub samples: usize,
    /// Support-vector budget.
    #[arg(long, default_value_t = DEFAULT_BUDGET)]
    pub budget: usize,
}

/// Runs `rlg bench-scale`: simulate a campaign, then time features + training to a reduced
/// model, and print the peak resident memory.
pub fn run_scale(a: &BenchScaleArgs) -> anyhow::Result<()> {
    let t0 = std::time::Instant::now();
    let rec = bench::campaign(a.samples, pipeline::DYNAMIC_SEED)?;
    let sim_s = t0.elapsed().as_secs_f64();
    let rss_sim = bench::peak_rss_bytes();
    let (_, r) = bench::train_scale(&rec, a.budget, pipeline::SIGMA, pipeline::C)?;
    let rss = bench::peak_rss_bytes();
    let mib = |b: Option<u64>| b.map_or(f64::NAN, |b| b as f64 / (1 << 20) as f64);
    println!(
        "campaign: {} samples at 1 Hz ({:.1} days), simulated in {sim_s:.2} s",
        rec.len(),
        rec.len() as f64 / 86_400.0
    );
    println!(
        "threads: {} (rayon); σ = {}, c = {}",
        rayon::current_num_threads(),
        pipeline::SIGMA,
        pipeline::C
    );
    println!("training samples:     {}", r.samples);
    println!("support vectors:      {}", r.support_vectors);
    println!("features (dT/dt):     {:.3} s", r.features_s);
    println!("fixed-size training:  {:.3} s", r.train_s);
    println!("training summary:     {:.3} s", r.summary_s);
    println!(
        "total (record → model): {:.3} s",
        r.features_s + r.train_s + r.summary_s
    );
    println!("training rms:         {:.3e} °/h", r.train_rms_dph);
    println!(
        "peak RSS (VmHWM):     {:.0} MiB (after simulation alone: {:.0} MiB)",
        mib(rss),
        mib(rss_sim)
    );
    Ok(())
}

/// faer's parallelism for the dense factorisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Par {
    /// One thread.
    Seq,
    /// The rayon pool (all cores).
    Rayon,
}

/// Arguments of `rlg bench-lssvm`.
#[derive(Debug, Args)]
pub struct BenchLssvmArgs {
    /// Folder for the shared data files `lssvm_<n>.csv` (written) and the timings JSON.
    #[arg(long, value_name = "DIR")]
    pub data_dir: PathBuf,
    /// Sizes n.
    #[arg(long, value_delimiter = ',', default_value = "1000,2000,5000")]
    pub sizes: Vec<usize>,
    /// Timed repetitions per measurement (median reported).
    #[arg(long, default_value_t = 7)]
    pub reps: usize,
    /// faer parallelism.
    #[arg(long, value_enum, default_value_t = Par::Rayon)]
    pub par: Par,
    /// Gaussian kernel width σ, standardised units (default: the pipeline's).
    #[arg(long, default_value_t = pipeline::SIGMA)]
    pub sigma: f64,
    /// Regularisation c (default: the pipeline's).
    #[arg(long, default_value_t = pipeline::C)]
    pub c: f64,
}

/// Runs `rlg bench-lssvm`: writes the data files and times the exact path on them; the
/// medians go to `<data_dir>/rust_<par>.json` for `bench/reference.py`.
pub fn run_lssvm(a: &BenchLssvmArgs) -> anyhow::Result<()> {
    faer::set_global_parallelism(match a.par {
        Par::Seq => faer::Par::Seq,
        Par::Rayon => faer::Par::rayon(rayon::current_num_threads()),
    });
    std::fs::create_dir_all(&a.data_dir)?;
    let (sigma, c) = (a.sigma, a.c);
    let mut json = Vec::new();
    println!(
        "{:>6} {:>11} {:>11} {:>11} {:>11} {:>14}  {:>9}  path   (faer {:?}, σ = {sigma}, c = {c}, median of {})",
        "n", "kernel s", "solve s", "f64 solve s", "solve+LOO s", "predict /s", "vs f64", a.par, a.reps
    );
    for &n in &a.sizes {
        let (z, y) = bench::bench_data(n)?;
        bench::write_bench_csv(&a.data_dir.join(format!("lssvm_{n}.csv")), &z, &y)?;
        let t = bench::time_exact(&z, &y, sigma, c, a.reps)?;
        println!(
            "{:>6} {:>11.4} {:>11.4} {:>11.4} {:>11.4} {:>14.3e}  {:>9.1e}  {:?}",
            n,
            t.kernel_s,
            t.solve_s,
            t.solve_f64_s,
            t.loo_s,
            t.predict_per_s,
            t.rel_diff_vs_f64,
            t.path
        );
        json.push(serde_json::json!({
            "n": n, "kernel_s": t.kernel_s, "solve_s": t.solve_s, "solve_f64_s": t.solve_f64_s,
            "loo_s": t.loo_s, "predict_per_s": t.predict_per_s,
            "rel_diff_vs_f64": t.rel_diff_vs_f64, "path": format!("{:?}", t.path),
        }));
    }
    let name = match a.par {
        Par::Seq => "rust_seq.json",
        Par::Rayon => "rust_rayon.json",
    };
    let doc = serde_json::json!({ "sigma": sigma, "c": c, "reps": a.reps, "rows": json });
    std::fs::write(
        a.data_dir.join(name),
        serde_json::to_string_pretty(&doc)? + "\n",
    )?;
    Ok(())
}

/// Arguments of `rlg sparse-report`.
#[derive(Debug, Args)]
pub struct SparseReportArgs {
    /// Support-vector budget of the reduced models.
    #[arg(long, default_value_t = DEFAULT_BUDGET)]
    pub budget: usize,
    /// Gaussian kernel width σ, standardised units.
    #[arg(long, default_value_t = pipeline::SIGMA)]
    pub sigma: f64,
    /// Regularisation c.
    #[arg(long, default_value_t = pipeline::C)]
    pub c: f64,
}

/// Runs `rlg sparse-report`: held-out 100 s stability of the full and reduced models on the
/// reference dynamic run.
pub fn run_sparse(a: &SparseReportArgs) -> anyhow::Result<()> {
    let run = pipeline::dynamic_run()?;
    let rows = sparse_eval::standard_recipes(a.budget)
        .iter()
        .map(|r| sparse_eval::held_out(&run, r, a.sigma, a.c))
        .collect::<Result<Vec<_>, _>>()?;
    println!(
        "trained on the first cycle (to {:.0} s), held out: cycles 2..{} ({:.0} s); σ = {}, c = {}",
        run.train_end_s(),
        run.cycles.len(),
        run.recording.time_s.last().copied().unwrap_or(0.0) - run.train_end_s(),
        a.sigma,
        a.c
    );
    print!("{}", sparse_eval::table(&rows));
    println!("board: exported f32 table through compensator_core::Compensator; f64: the model file on the host features");
    Ok(())
}
