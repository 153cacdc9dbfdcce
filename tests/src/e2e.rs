//! The README's main job: train on the shipped data, export the table, run the board image in
//! QEMU on the held-out part of the record and check it against the host, printing figures.

use std::path::Path;
use std::time::Duration;

use anyhow::{ensure, Context as _};
use compensator_core::{Compensator, SensorLimits};
use rlg_eval::metrics::bias_stability_dph;
use rlg_repro::pipeline;
use rlg_train::{export, features};

use crate::firmware;
use crate::replay::{self, ReplaySample};

/// 100 s at 1 Hz.
const WINDOW: usize = 100;

/// What the main job measured.
#[derive(Clone, Debug)]
pub struct E2eReport {
    /// Support vectors in the default table.
    pub support_vectors: usize,
    /// TRAINING RMS on the first cycle's 100 s means, °/h.
    pub train_rms_dph: f64,
    /// Held-out samples (cycles 2…), 1 Hz.
    pub test_samples: usize,
    /// Held-out 100 s stability, raw, °/h.
    pub test_b100_raw_dph: f64,
    /// Held-out 100 s stability after the board's f32 compensation, °/h.
    pub test_b100_comp_dph: f64,
    /// Max |f32 board correction − f64 trainer correction| over the held-out samples, °/h.
    pub max_f32_vs_f64_dph: f64,
    /// Whether the committed firmware table equals a fresh export.
    pub committed_table_fresh: bool,
    /// Samples the QEMU image produced, and how many matched the host bit for bit.
    pub board_samples: usize,
    /// See `board_samples`.
    pub board_identical: usize,
    /// Held-out 100 s stability of the board's own output, °/h.
    pub board_b100_dph: f64,
    /// The image's decoded defmt log.
    pub board_log: Vec<String>,
}

/// Replays `samples` through a host `Compensator` of `model` (fresh, as the image starts)
/// and compares each output with the board's record: returns how many are identical in
/// rate, correction and status bits, and the board's output rates.
pub fn compare_with_host<const D: usize>(
    model: compensator_core::ModelRef<'_, D>,
    samples: &[ReplaySample],
    records: &[firmware::OutputRecord],
) -> (usize, Vec<f64>) {
    let mut host = Compensator::new(model, SensorLimits::DEFAULT);
    let mut identical = 0;
    let mut board_out = Vec::with_capacity(samples.len());
    for (s, r) in samples.iter().zip(records) {
        let want = host.update(s.temp_c, s.rate_dph);
        board_out.push(f64::from(f32::from_bits(r.rate_dph_bits)));
        identical += usize::from(
            (r.rate_dph_bits, r.correction_dph_bits, r.status)
                == (
                    want.rate_dph.to_bits(),
                    want.correction_dph.to_bits(),
                    want.status.0,
                ),
        );
    }
    (identical, board_out)
}

/// Runs the whole slice; `out` receives the model, table and replay files.
pub fn run(out: &Path) -> anyhow::Result<E2eReport> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let (run, model) = pipeline::default_model()?;
    model.write(&out.join("model.json"))?;
    let source = export::table_source(&model, pipeline::DEFAULT_TABLE_COMMAND)?;
    rlg_train::model::write_atomic(&out.join("model_table.rs"), source.as_bytes())?;
    let committed =
        std::fs::read_to_string(firmware::workspace_root().join("firmware/src/model_table.rs"))?;

    // The board's path on the host: f32 features and Eq. (10) in f32, vs the f64 model on
    // the very same features.
    let rec = &run.recording;
    let split = rec.time_s.partition_point(|t| *t < run.train_end_s());
    let f32_model = export::to_f32::<2>(&model)?;
    let series = features::compute(
        &[
            compensator_core::Feature::TempC,
            compensator_core::Feature::TempRateCPerS,
        ],
        &rec.temp_c,
        &rec.time_s,
        model.rate_tau_s,
        model.dt_s,
    )?;
    let mut comp = Compensator::new(f32_model.as_model(), SensorLimits::DEFAULT);
    ensure!(comp.table_ok(), "exported table fails validation");
    let mut compensated = Vec::with_capacity(rec.len() - split);
    let mut max_diff = 0.0f64;
    for k in 0..rec.len() {
        let out = comp.update(rec.temp_c[k] as f32, rec.rate_dph[k] as f32);
        if k < split {
            continue;
        }
        compensated.push(f64::from(out.rate_dph));
        if out.status.is_ok() {
            let x: Vec<f64> = series.rows[k].to_vec();
            let reference = model.correction_dph(&x);
            max_diff = max_diff.max((f64::from(out.correction_dph) - reference).abs());
        }
    }
    let raw = &rec.rate_dph[split..];

    // The board image on the held-out part, bit for bit against the host.
    let samples: Vec<ReplaySample> = (split..rec.len())
        .map(|k| ReplaySample {
            temp_c: rec.temp_c[k] as f32,
            rate_dph: rec.rate_dph[k] as f32,
        })
        .collect();
    let bin = out.join("replay-heldout.bin");
    replay::write(&bin, &samples)?;
    let elf = out.join("firmware-heldout.elf");
    firmware::build_image(&bin, &elf)?;
    let qemu = firmware::run_qemu(&elf, Duration::from_secs(600))?;
    ensure!(
        qemu.exit_code == Some(0),
        "QEMU exited with {:?}",
        qemu.exit_code
    );
    let (identical, board_out) = compare_with_host(f32_model.as_model(), &samples, &qemu.records);

    Ok(E2eReport {
        support_vectors: model.lssvm.support.len(),
        train_rms_dph: model.training.rms_dph,
        test_samples: raw.len(),
        test_b100_raw_dph: bias_stability_dph(raw, WINDOW).unwrap_or(f64::NAN),
        test_b100_comp_dph: bias_stability_dph(&compensated, WINDOW).unwrap_or(f64::NAN),
        max_f32_vs_f64_dph: max_diff,
        committed_table_fresh: committed == source,
        board_samples: qemu.records.len(),
        board_identical: identical,
        board_b100_dph: bias_stability_dph(&board_out, WINDOW).unwrap_or(f64::NAN),
        board_log: qemu.log,
    })
}
