//! `rlg train`: fit an LS-SVM on Table 1 or on a recording and write the model file.

use std::path::PathBuf;

use clap::Args;

use rlg_calibrate::train::{train_model, TrainData, TrainOptions};
use rlg_io::progress::progress;
use rlg_train::dataset::{self, RecordingSelection};
use rlg_train::model::Provenance;

/// Arguments of `rlg train`.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("data").required(true).args(["table1", "recording"])))]
pub struct TrainArgs {
    /// The paper's Table 1 as CSV (columns temp_c, rate_dph; `#` comments): one feature, temp_c.
    #[arg(long = "table", visible_alias = "table1", value_name = "FILE")]
    pub table1: Option<PathBuf>,
    /// How the recording is written (separator, columns, units).
    #[command(flatten)]
    pub input: super::InputArgs,
    /// A recording (time_s, rate_dph, temp_c, or the columns --time-col, --rate-col,
    /// --temp-col name): features temp_c and temp_rate_c_per_s.
    #[arg(long, value_name = "FILE")]
    pub recording: Option<PathBuf>,
    /// Train on samples from this time on, s (recording only).
    #[arg(long, value_name = "S", requires = "recording")]
    pub from_s: Option<f64>,
    /// Train on samples up to this time, s (recording only).
    #[arg(long, value_name = "S", requires = "recording")]
    pub to_s: Option<f64>,
    /// Average features and targets over blocks of N samples (recording only; 100: the paper's
    /// 100 s means; 1: raw 1 Hz).
    #[arg(long, value_name = "N", default_value_t = rlg_train::protocol::TRAIN_BLOCK, requires = "recording")]
    pub block: usize,
    /// Gaussian kernel width σ of Eq. (8), in standardised input units [default: tuned by
    /// cross-validation, with --c].
    #[arg(long, value_name = "SIGMA", requires = "c")]
    pub sigma: Option<f64>,
    /// Regularisation c of Eq. (9) [default: tuned by cross-validation, with --sigma].
    #[arg(long, value_name = "C", requires = "sigma")]
    pub c: Option<f64>,
    /// Train a reduced (fixed-size) model of at most M support vectors: memory grows as
    /// samples × M instead of samples² [default: the exact model].
    #[arg(long, value_name = "M", value_parser = clap::value_parser!(u64).range(1..=100_000))]
    pub budget: Option<u64>,
    /// Time constant of the dT/dt estimator, s.
    #[arg(long, value_name = "S", default_value_t = 60.0)]
    pub rate_tau_s: f64,
    /// Also compute the leave-one-out (PRESS) RMS, in closed form.
    #[arg(long)]
    pub loo: bool,
    /// Output model file.
    #[arg(long, value_name = "FILE", default_value = "model.json")]
    pub out: PathBuf,
}

/// Runs `rlg train`.
pub fn run(a: &TrainArgs, command_line: &str) -> anyhow::Result<()> {
    super::check_output_file(&a.out, "--out")?;
    let (path, data) = match (&a.table1, &a.recording) {
        (Some(p), _) => (p, TrainData::Table1(dataset::table1_from_csv(p)?)),
        (None, Some(p)) => {
            let sel = RecordingSelection {
                from_s: a.from_s,
                to_s: a.to_s,
                block: a.block,
                rate_tau_s: a.rate_tau_s,
            };
            (
                p,
                TrainData::Recording(super::read_recording(p, &a.input)?, sel),
            )
        }
        (None, None) => anyhow::bail!("give --table FILE or --recording FILE"),
    };
    let provenance = Provenance::from_file(path, command_line)?;
    let opts = TrainOptions {
        sigma_c: a.sigma.zip(a.c),
        budget: a.budget.map(|b| b as usize),
        loo: a.loo,
        rate_tau_s: a.rate_tau_s,
    };
    let pb = progress("tuning σ, c");
    let trained = train_model(data, &opts, &path.display().to_string(), provenance, &pb)?;
    if let Some(t) = &trained.tuned {
        println!(
            "σ = {:.4}, c = {:.4} by {}: CROSS-VALIDATED RMS {:.4e} °/h",
            t.sigma, t.c, t.validation, t.cv_rms_dph
        );
    }
    let m = &trained.model;
    m.write(&a.out)?;
    let t = &m.training;
    println!(
        "trained on {} samples, features [{}]",
        t.samples,
        m.lssvm.features.join(", ")
    );
    println!("TRAINING RMS error:      {:.4e} °/h", t.rms_dph);
    println!("TRAINING max |error|:    {:.4e} °/h", t.max_abs_dph);
    if let Some(l) = t.loo_rms_dph {
        println!("leave-one-out RMS error: {l:.4e} °/h");
    }
    println!(
        "reference output f({:?}) = {:.6} °/h",
        m.reference_input, m.reference_dph
    );
    println!("wrote {}", a.out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::export::{self, ExportArgs};

    /// The two commands end to end on a small static table: the model file is readable, its
    /// training errors are those of its own predictions, and the table is generated.
    #[test]
    fn train_then_export_on_a_static_table() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("static.csv");
        let rows: String = (0..9)
            .map(|i| {
                let t = -30.0 + 11.0 * f64::from(i);
                format!("{t},{},0\n", -7.1 - 4e-4 * t + 3e-6 * t * t)
            })
            .collect();
        std::fs::write(&csv, format!("# test\ntemp_c,rate_dph,other\n{rows}")).unwrap();
        let model = dir.path().join("m.json");
        let args = TrainArgs {
            table1: Some(csv.clone()),
            input: crate::cli::InputArgs::default(),
            recording: None,
            from_s: None,
            to_s: None,
            block: 1,
            sigma: Some(1.0),
            c: Some(1e4),
            budget: None,
            rate_tau_s: 60.0,
            loo: true,
            out: model.clone(),
        };
        run(&args, "rlg train").unwrap();
        let m = rlg_train::model::ModelFile::read(&model).unwrap();
        assert_eq!(m.provenance.data_file, "static.csv");
        assert_eq!(m.training.samples, 9);
        assert!(m.training.loo_rms_dph.unwrap() > m.training.rms_dph);
        let d = dataset::table1_from_csv(&csv).unwrap();
        let max =
            d.x.iter()
                .zip(&d.y_dph)
                .map(|(x, y)| (m.predict_dph(x) - y).abs())
                .fold(0.0, f64::max);
        assert_eq!(max, m.training.max_abs_dph);

        let out = dir.path().join("table.rs");
        let args = |out: &std::path::Path, format| ExportArgs {
            model: model.clone(),
            out: out.to_path_buf(),
            format,
            name: rlg_train::export_c::CName::default(),
        };
        export::run(&args(&out, None), "rlg export").unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(text.starts_with("// @generated by rlg export — do not edit\n"));
        assert!(text.contains("ModelTable<9, 1>"));
        // The C header from the extension; a flag that contradicts it writes nothing.
        let h = dir.path().join("m_table.h");
        export::run(&args(&h, None), "rlg export").unwrap();
        assert!(std::fs::read_to_string(&h)
            .unwrap()
            .contains("#define RLG_N 9"));
        let h2 = dir.path().join("other.h");
        let e = export::run(&args(&h2, Some(export::FormatArg::Rust)), "rlg export").unwrap_err();
        assert!(e.to_string().contains("--format rust"), "{e}");
        assert!(!h2.exists());
    }
}
