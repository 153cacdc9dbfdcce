//! Measurements behind `rlg bench-scale` and `rlg bench-lssvm`: training time and peak memory
//! on long campaigns, and exact-solve timings on data files shared with the Python reference
//! (`host-trainer/benchmarks/reference/reference.py`).

use std::path::Path;
use std::time::Instant;

use rlg_io::recording::Recording;
use rlg_repro::pipeline;
use rlg_simulate::{simulate, Scenario};
use rlg_train::dataset::{self, RecordingSelection};
use rlg_train::lssvm::solve::{solve_f64, solve_reporting, solve_with_loo, SolvePath};
use rlg_train::lssvm::sparse::{train_reduced, Reduction};
use rlg_train::lssvm::{kernel_matrix, solve, Lssvm};
use rlg_train::model::{ModelFile, Provenance};

/// Peak resident set size of this process so far (`VmHWM` of /proc/self/status), bytes.
/// `None` where the file does not exist (not Linux).
pub fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// A multi-day 1 Hz campaign: the shipped dynamic scenario (10 ↔ 65 °C, 3 h holds, 1 °C/min
/// ramps, 7.8 h per cycle) repeated until at least `samples` samples, then cut to `samples`.
pub fn campaign(samples: usize, seed: u64) -> anyhow::Result<Recording> {
    let base = Scenario::from_toml_str(
        pipeline::DYNAMIC_SCENARIO_TOML,
        pipeline::DYNAMIC_SCENARIO_PATH,
    )?;
    let per_cycle_s = base.duration() / 4.0;
    let cycles = ((samples as f64 / per_cycle_s).ceil() as u32).max(1);
    anyhow::ensure!(
        pipeline::DYNAMIC_SCENARIO_TOML.contains("count = 4"),
        "the shipped dynamic scenario no longer repeats 4 cycles"
    );
    let text =
        pipeline::DYNAMIC_SCENARIO_TOML.replacen("count = 4", &format!("count = {cycles}"), 1);
    let scenario = Scenario::from_toml_str(&text, "campaign")?;
    let mut rec = simulate(&scenario, seed)?.recording;
    let n = samples.min(rec.len());
    rec.time_s.truncate(n);
    rec.rate_dph.truncate(n);
    rec.temp_c.truncate(n);
    if let Some(c) = rec.chamber_c.as_mut() {
        c.truncate(n);
    }
    rec.extra.clear();
    Ok(rec)
}

/// Timings of one training from a raw recording to a reduced model.
#[derive(Clone, Debug, PartialEq)]
pub struct ScaleReport {
    /// Training samples (raw 1 Hz, after the dT/dt warm-up).
    pub samples: usize,
    /// Support vectors of the model.
    pub support_vectors: usize,
    /// Features: the board's pipeline over the record, s.
    pub features_s: f64,
    /// Active-set search + Nyström primal solve, s.
    pub train_s: f64,
    /// Training residuals, range and reference ([`ModelFile::from_trained`]), s.
    pub summary_s: f64,
    /// RMS training residual, °/h.
    pub train_rms_dph: f64,
}

/// Trains a fixed-size model with `budget` support vectors on every sample of `rec` (no
/// block averaging), timing each stage.
pub fn train_scale(
    rec: &Recording,
    budget: usize,
    sigma: f64,
    c: f64,
) -> anyhow::Result<(ModelFile, ScaleReport)> {
    let t0 = Instant::now();
    let sel = RecordingSelection {
        from_s: None,
        to_s: None,
        block: 1,
        rate_tau_s: pipeline::RATE_TAU_S,
    };
    let data = dataset::from_recording(rec, &sel)?;
    let t1 = Instant::now();
    let model = train_reduced(
        &data.features,
        &data.x,
        &data.y_dph,
        sigma,
        c,
        budget,
        Reduction::FIXED_SIZE,
    )?;
    let t2 = Instant::now();
    let prov = Provenance::from_bytes("campaign", b"", "rlg bench-scale");
    let m = ModelFile::from_trained(
        model,
        &data.x,
        &data.y_dph,
        pipeline::RATE_TAU_S,
        data.dt_s,
        None,
        prov,
    )?;
    let t3 = Instant::now();
    let report = ScaleReport {
        samples: data.x.len(),
        support_vectors: m.lssvm.support.len(),
        features_s: (t1 - t0).as_secs_f64(),
        train_s: (t2 - t1).as_secs_f64(),
        summary_s: (t3 - t2).as_secs_f64(),
        train_rms_dph: m.training.rms_dph,
    };
    Ok((m, report))
}

/// The shared benchmark data: `n` standardised 2-D inputs and targets from the reference run's
/// raw 1 Hz first cycle, every k-th sample so that the `n` points span the cycle.
pub fn bench_data(n: usize) -> anyhow::Result<(Vec<Vec<f64>>, Vec<f64>)> {
    let run = pipeline::dynamic_run()?;
    let sel = RecordingSelection {
        from_s: None,
        to_s: Some(run.train_end_s()),
        block: 1,
        rate_tau_s: pipeline::RATE_TAU_S,
    };
    let d = dataset::from_recording(&run.recording, &sel)?;
    anyhow::ensure!(
        d.x.len() >= n,
        "only {} samples in the first cycle",
        d.x.len()
    );
    let step = d.x.len() / n;
    let x: Vec<Vec<f64>> = (0..n).map(|i| d.x[i * step].clone()).collect();
    let y: Vec<f64> = (0..n).map(|i| d.y_dph[i * step]).collect();
    let scaling = rlg_train::lssvm::Scaling::fit(&d.features, &x)?;
    Ok((x.iter().map(|r| scaling.apply(r)).collect(), y))
}

/// Writes `z0,z1,y` rows (full precision) for the Python reference.
pub fn write_bench_csv(path: &Path, z: &[Vec<f64>], y: &[f64]) -> anyhow::Result<()> {
    let mut s = String::from("z0,z1,y\n");
    for (r, v) in z.iter().zip(y) {
        s += &format!("{:?},{:?},{v:?}\n", r[0], r[1]);
    }
    std::fs::write(path, s)?;
    Ok(())
}

/// Median of `reps` timings of `f`, s (after one warm-up call).
pub fn median_s<F: FnMut()>(reps: usize, mut f: F) -> f64 {
    f();
    let mut t: Vec<f64> = (0..reps.max(1))
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// Median timings of the exact path at one size, s.
#[derive(Clone, Debug, PartialEq)]
pub struct ExactTimings {
    /// Samples.
    pub n: usize,
    /// Kernel matrix alone.
    pub kernel_s: f64,
    /// Eq. (9) by [`solve`]: kernel matrix and two solves (iterative from
    /// `MIXED_MIN_N` samples on).
    pub solve_s: f64,
    /// Eq. (9) by the f64 Cholesky alone.
    pub solve_f64_s: f64,
    /// How [`solve`] solved it.
    pub path: SolvePath,
    /// Largest |a_i − a_i(f64)| / max |a(f64)| and |b − b(f64)| / max |a(f64)|.
    pub rel_diff_vs_f64: f64,
    /// Eq. (9) plus closed-form LOO residuals.
    pub loo_s: f64,
    /// Predictions per second of the trained n-vector model (f64, one thread).
    pub predict_per_s: f64,
}

/// Times the exact solve, the LOO and prediction on `z`, `y` with σ, c.
pub fn time_exact(
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
    reps: usize,
) -> anyhow::Result<ExactTimings> {
    solve(z, y, sigma, c)?;
    let kernel_s = median_s(reps, || {
        std::hint::black_box(kernel_matrix(z, sigma));
    });
    let solve_s = median_s(reps, || {
        std::hint::black_box(solve(z, y, sigma, c).ok());
    });
    let solve_f64_s = median_s(reps, || {
        std::hint::black_box(solve_f64(z, y, sigma, c).ok());
    });
    let (mixed, path) = solve_reporting(z, y, sigma, c)?;
    let exact = solve_f64(z, y, sigma, c)?;
    let scale = exact.alpha.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    let rel_diff_vs_f64 = mixed
        .alpha
        .iter()
        .zip(&exact.alpha)
        .map(|(a, b)| (a - b).abs())
        .fold((mixed.bias - exact.bias).abs(), f64::max)
        / scale;
    let loo_s = median_s(reps, || {
        std::hint::black_box(solve_with_loo(z, y, sigma, c).ok());
    });
    let sol = solve(z, y, sigma, c)?;
    let model = Lssvm {
        features: vec!["temp_c".into(), "temp_rate_c_per_s".into()],
        scaling: rlg_train::lssvm::Scaling {
            mean: vec![0.0; 2],
            scale: vec![1.0; 2],
        },
        support: z.to_vec(),
        alpha_dph: sol.alpha,
        bias_dph: sol.bias,
        sigma,
        c,

        in_kernel: Vec::new(),
        linear_dph: Vec::new(),
    };
    let queries = 2000.min(z.len());
    // Batch prediction, as KernelRidge's `predict` is: the predictor lays the support
    // vectors out once per batch (inside the timing), then each query is one pass over them.
    let predict_s = median_s(reps, || {
        let p = model.predictor();
        for q in &z[..queries] {
            std::hint::black_box(p.predict(q));
        }
    });
    Ok(ExactTimings {
        n: z.len(),
        kernel_s,
        solve_s,
        solve_f64_s,
        path,
        rel_diff_vs_f64,
        loo_s,
        predict_per_s: queries as f64 / predict_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peak_rss_is_read_on_linux() {
        if cfg!(target_os = "linux") {
            let b = peak_rss_bytes().unwrap();
            // Any process holds at least a few hundred KiB and (here) less than 64 GiB.
            assert!(b > 100 * 1024 && b < 64 << 30, "{b}");
        }
    }

    /// The campaign has the requested length at 1 Hz.
    #[test]
    fn campaign_has_the_requested_length() {
        let rec = campaign(40_000, pipeline::DYNAMIC_SEED).unwrap();
        assert_eq!(rec.len(), 40_000);
        assert_eq!(rec.time_s[39_999] - rec.time_s[0], 39_999.0);
    }
}
