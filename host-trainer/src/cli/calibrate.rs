//! `rlg calibrate`: a chamber recording (and optionally a later test recording) to a tuned
//! board table, the comparison with the baselines, and a report folder.

use std::path::{Path, PathBuf};

use clap::Args;

use rlg_calibrate::report::{self, FileInfo, Inputs};
use rlg_calibrate::static_cal::{calibrate_static, StaticOptions};
use rlg_calibrate::{calibrate, Options};
use rlg_io::progress::progress;
use rlg_train::model::Provenance;

/// Arguments of `rlg calibrate`.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// The calibration recording (time_s, rate_dph, temp_c; a continuous 1 Hz stream, or
    /// burst / plateau means with --static).
    #[arg(long, value_name = "FILE")]
    pub recording: PathBuf,
    /// A later recording of the same gyro, held out entirely (otherwise the later temperature
    /// cycles of --recording are held out).
    #[arg(long, value_name = "FILE")]
    pub test: Option<PathBuf>,
    /// Units of the recordings' columns.
    #[command(flatten)]
    pub units: super::UnitArgs,
    /// Output folder: report.md, summary.json, PNG figures, model.json, table.rs, table.h
    /// (with --diagnose, when the diagnosed inputs are adopted, also model_diagnosed.json,
    /// table_diagnosed.rs, table_diagnosed.h).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Support vectors of the board table (its capacity).
    #[arg(long, value_name = "M", default_value_t = rlg_train::protocol::SUPPORT_VECTORS as u64,
          value_parser = clap::value_parser!(u64).range(1..=rlg_calibrate::MAX_BUDGET as u64))]
    pub budget: u64,
    /// Temperature cycles of --recording that train [default: half of them, rounded up,
    /// leaving at least one held out].
    #[arg(long, value_name = "N", conflicts_with = "test")]
    pub train_cycles: Option<usize>,
    /// Window of the bias stability, samples at 1 Hz (100: the 100 s stability).
    #[arg(long, value_name = "S", default_value_t = 100,
          value_parser = clap::value_parser!(u64).range(2..=100_000))]
    pub window: u64,
    /// Train on means of N samples (100: the paper's 100 s means; 1: raw 1 Hz).
    #[arg(long, value_name = "N", default_value_t = rlg_train::protocol::TRAIN_BLOCK as u64,
          value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub block: u64,
    /// Use samples from this time on, s.
    #[arg(long, value_name = "S")]
    pub from_s: Option<f64>,
    /// Use samples up to this time, s.
    #[arg(long, value_name = "S")]
    pub to_s: Option<f64>,
    /// Time constant of the board's dT/dt estimator, s.
    #[arg(long, value_name = "S", default_value_t = rlg_train::protocol::RATE_TAU_S)]
    pub rate_tau_s: f64,
    /// Smallest c of the tuning grid (lower it when no c meets the board's f32 limit).
    #[arg(long, value_name = "C", default_value_t = 0.1)]
    pub c_min: f64,
    /// Weight training evenly over temperature: pool the training means into cells of one
    /// cycle, 1 °C and a tenth of the largest |dT/dt|, one mean each, so slow stretches of an
    /// uneven ramp do not dominate the fit.
    #[arg(long)]
    pub even_temperature: bool,
    /// Also diagnose the training span for missing physics and, where the close loop adopts
    /// the diagnosed features by cross-validation, compare that model on the same held-out
    /// samples (`rlg close-loop`'s protocol) and write its board table beside the
    /// [T, dT/dt] one.
    #[arg(long, conflicts_with = "static_only")]
    pub diagnose: bool,
    /// Physics model the diagnosis starts from (TOML `[[terms]]` or a scenario file; `rlg
    /// terms`) [default: the paper's].
    #[arg(long, value_name = "FILE", requires = "diagnose")]
    pub model: Option<PathBuf>,
    /// Static characterisation: a temperature-only model from burst or plateau means (a
    /// bursty log has no 1 Hz stream, so no dT/dt model).
    #[arg(long = "static")]
    pub static_only: bool,
}

fn file_info(path: &Path, samples: usize) -> anyhow::Result<FileInfo> {
    let p = Provenance::from_file(path, "")?;
    Ok(FileInfo {
        file: p.data_file,
        sha256: p.data_sha256,
        samples,
    })
}

/// Runs `rlg calibrate`.
pub fn run(a: &CalibrateArgs, command_line: &str) -> anyhow::Result<()> {
    // The folder first: a path that cannot hold it fails before minutes of work.
    report::prepare_dir(&a.out)?;
    anyhow::ensure!(
        a.c_min > 0.0 && a.c_min.is_finite(),
        "--c-min {}: c must be positive",
        a.c_min
    );
    let cal = super::read_recording(&a.recording, &a.units)?;
    let test = match &a.test {
        Some(p) => Some(super::read_recording(p, &a.units)?),
        None => None,
    };
    let inputs = Inputs {
        command: command_line.to_string(),
        recording: file_info(&a.recording, cal.len())?,
        test_recording: match (&a.test, &test) {
            (Some(p), Some(t)) => Some(file_info(p, t.len())?),
            _ => None,
        },
    };
    let provenance = Provenance::from_file(&a.recording, command_line)?;
    let mut grid = rlg_train::lssvm::tune::Grid::default();
    anyhow::ensure!(
        a.c_min < grid.c.1,
        "--c-min {} is above the grid's largest c {}",
        a.c_min,
        grid.c.1
    );
    grid.c.0 = a.c_min;
    if a.static_only {
        let opts = StaticOptions {
            block: a.block as usize,
            budget: a.budget as usize,
            grid,
            rate_tau_s: a.rate_tau_s,
        };
        let c = calibrate_static(
            &cal,
            test.as_ref(),
            &opts,
            &provenance,
            &progress("tuning σ, c (static)"),
        )?;
        let files = report::write_static(&c, &inputs, &a.out)?;
        let s = report::static_summary(&c, &inputs, &[]);
        for m in &s.models {
            println!(
                "{:<18} TRAINING rms {:.3e}  CV rms {}  HELD-OUT rms {}",
                m.name,
                m.train_rms_dph.unwrap_or(f64::NAN),
                m.cv_rms_dph.map_or("—".into(), |v| format!("{v:.3e}")),
                m.held_out
                    .as_ref()
                    .map_or("— (no --test)".into(), |h| format!(
                        "{:.3e}",
                        h.stability_dph
                    ))
            );
        }
        println!("wrote {} files to {}", files.len(), a.out.display());
        return Ok(());
    }
    let opts = Options {
        train_cycles: a.train_cycles,
        window: a.window as usize,
        block: a.block as usize,
        budget: a.budget as usize,
        rate_tau_s: a.rate_tau_s,
        grid,
        from_s: a.from_s,
        to_s: a.to_s,
        even_temperature: a.even_temperature,
        ..Options::default()
    };
    let mut c = calibrate(
        &cal,
        test.as_ref(),
        &opts,
        &provenance,
        &progress("tuning σ, c"),
    )?;
    if a.diagnose {
        diagnosed_row(a, &cal, test.as_ref(), &mut c, &provenance)?;
    }
    let files = report::write(&c, &inputs, &a.out)?;
    let md = report::markdown(&c, &inputs);
    // The comparison table and the notes, as in report.md.
    if let Some(start) = md.find("## Comparison") {
        let end = md[start..]
            .find("## Allan")
            .or_else(|| md[start..].find("## Board"))
            .map_or(md.len(), |e| start + e);
        print!("{}", &md[start..end]);
    }
    for n in &c.notes {
        println!("note: {n}");
    }
    println!(
        "board table: σ = {:.4}, c = {:.4}, {} vectors, f32 within {:.1e} °/h",
        c.board.sigma, c.board.c, c.board.support_vectors, c.board.f32_deviation_dph
    );
    if let Some(d) = &c.diagnosed_board {
        let l = &d.model.lssvm;
        println!(
            "board table on the diagnosed features [{}]: σ = {:.4}, c = {:.4}, {} vectors, f32 \
             within {:.1e} °/h",
            l.features.join(", "),
            l.sigma,
            l.c,
            l.support.len(),
            d.f32_deviation_dph
        );
    }
    println!(
        "wrote {} files to {} (report: {})",
        files.len(),
        a.out.display(),
        a.out.join("report.md").display()
    );
    Ok(())
}

/// The close loop on the calibration's split: diagnose the training span, turn the findings
/// into board features, and where cross-validation adopts them add the model's row, scored
/// on the held-out samples as the others are; otherwise a note says why not.
fn diagnosed_row(
    a: &CalibrateArgs,
    cal: &rlg_io::recording::Recording,
    test: Option<&rlg_io::recording::Recording>,
    c: &mut rlg_calibrate::Calibration,
    provenance: &Provenance,
) -> anyhow::Result<()> {
    use compensator_core::Feature;
    use rlg_calibrate::{DiagnosedBoard, HeldOut, HeldOutScore, ModelRow};
    use rlg_closeloop::{
        augmented_features, train_and_score, train_and_score_on, Inputs, Protocol,
    };
    use rlg_diagnose::{diagnose, DiagnoseError, Options as DiagnoseOptions, PhysicsModel};
    use rlg_eval::metrics::allan::{octave_clusters, overlapping_adev_ci, CONFIDENCE_1SIGMA};
    use rlg_eval::metrics::compare::improvement_factor;
    use rlg_eval::metrics::stability::bias_stability_gapless_dph;

    if matches!(c.split.held_out, HeldOut::Nothing) {
        c.notes.push(
            "--diagnose: nothing is held out, so a diagnosed-feature model cannot be compared."
                .into(),
        );
        return Ok(());
    }
    let end = c.split.train_span_s.1;
    let model = match &a.model {
        Some(p) => PhysicsModel::read(p)?,
        None => PhysicsModel::paper(),
    };
    let train_part = cal.head(cal.time_s.partition_point(|t| *t <= end));
    let pb = progress("diagnosing the training span");
    let d = match diagnose(&train_part, &model, &DiagnoseOptions::default()) {
        Ok(d) => d,
        Err(e @ DiagnoseError::TooShort { .. }) => {
            pb.finish_and_clear();
            c.notes.push(format!(
                "--diagnose: the training span cannot be diagnosed ({e})."
            ));
            return Ok(());
        }
        Err(e) => return Err(e.into()),
    };
    pb.finish_and_clear();
    let (feats, suggestions) = augmented_features(&d);
    if feats == Inputs::base() {
        c.notes.push(format!(
            "--diagnose: the diagnosis of the training span names no mechanism a board feature \
             carries (verdict {:?}{}); no diagnosed-feature model.",
            d.verdict,
            suggestions
                .iter()
                .map(|s| format!("; {}: {}", s.mechanism, s.reason))
                .collect::<String>()
        ));
        return Ok(());
    }
    let protocol = Protocol {
        budget: Some(c.options.budget),
        ..Protocol::default()
    };
    let score = |inputs: &Inputs| match test {
        Some(t) => train_and_score_on(cal, t, inputs, &protocol, provenance),
        None => train_and_score(cal, end, inputs, &protocol, provenance),
    };
    let pb = progress("close loop: base and diagnosed features");
    let base = score(&Inputs::base())?;
    let aug = score(&feats)?;
    pb.finish_and_clear();
    let described = aug.inputs.describe().join(", ");
    if !protocol.adopts(&base, &aug) {
        c.notes.push(format!(
            "--diagnose: the diagnosed features [{described}] are not adopted: their CV rms \
             {:.3e} °/h is not {:.0} % below the [T, dT/dt] model's {:.3e} °/h (held out, for the \
             record: {:.3e} against {:.3e} °/h).",
            aug.cv_rms_dph,
            100.0 * protocol.adopt_margin,
            base.cv_rms_dph,
            aug.test_b100_dph,
            base.test_b100_dph
        ));
        return Ok(());
    }
    // Its table, under the same f32 limit as the [T, dT/dt] table's.
    let table = match rlg_train::export::precision(&aug.model) {
        Ok(p) if p.deviation_dph <= p.limit_dph => {
            c.diagnosed_board = Some(DiagnosedBoard {
                model: aug.model.clone(),
                f32_deviation_dph: p.deviation_dph,
                f32_limit_dph: p.limit_dph,
                board_stability_dph: aug.board_b100_dph,
            });
            "Its board table: `table_diagnosed.rs`, `table_diagnosed.h`, \
             `model_diagnosed.json`."
                .to_string()
        }
        Ok(p) => format!(
            "Its board table is not written: its f32 evaluation departs by {:.2e} °/h, beyond \
             the limit {:.1e} °/h (lower --c-min).",
            p.deviation_dph, p.limit_dph
        ),
        Err(e) => format!("Its board table is not written: {e}."),
    };
    let stream = test.unwrap_or(cal);
    let k0 = aug.test_from;
    let time = &stream.time_s[k0..];
    let out: Vec<f64> = stream.rate_dph[k0..]
        .iter()
        .zip(&aug.test_correction_dph)
        .map(|(r, k)| r - k)
        .collect();
    let rate = rlg_train::features::compute(
        &[Feature::TempRateCPerS],
        &stream.temp_c,
        &stream.time_s,
        c.options.rate_tau_s,
        1.0,
    )?;
    let rate: Vec<f64> = rate.rows.iter().skip(k0).map(|r| r[0]).collect();
    let w = c.options.window;
    let raw_b = bias_stability_gapless_dph(time, &stream.rate_dph[k0..], w);
    let b = bias_stability_gapless_dph(time, &out, w).unwrap_or(f64::NAN);
    c.notes.push(format!(
        "--diagnose: the close loop adopts the diagnosed features [{described}] (CV rms {:.3e} \
         against {:.3e} °/h); their model is scored on the held-out samples from {:.0} s (the \
         close loop's split: {} sample(s) from the other rows'). {}",
        aug.cv_rms_dph,
        base.cv_rms_dph,
        time[0],
        {
            let k = stream.time_s.partition_point(|t| *t < c.series.start_s);
            k.abs_diff(k0)
        },
        table
    ));
    c.rows.push(ModelRow {
        name: "diagnosed features (close loop)".into(),
        detail: format!("[{described}], σ = {:.3}, c = {:.3}", aug.sigma, aug.c),
        train_rms_dph: Some(aug.train_rms_dph),
        cv_rms_dph: Some(aug.cv_rms_dph),
        held_out: Some(HeldOutScore {
            stability_dph: b,
            improvement: raw_b.and_then(|r| improvement_factor(r, b)),
            phases: rlg_calibrate::phases::phase_rms(time, &rate, &out, w),
            allan: overlapping_adev_ci(&out, 1.0, &octave_clusters(out.len()), CONFIDENCE_1SIGMA),
        }),
    });
    Ok(())
}
