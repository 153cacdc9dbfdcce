//! `rlg resample`: a high-rate, jittered or bursty log to the recording the trainer reads
//! (rules: [`rlg_io::resample`]).

use std::path::PathBuf;

use rlg_io::resample::{bin_means, burst_means};

/// Arguments of `rlg resample`.
#[derive(Debug, clap::Args)]
pub struct ResampleArgs {
    /// Input recording (CSV).
    #[arg(long, value_name = "FILE")]
    pub recording: PathBuf,
    /// How the input is written (separator, columns, units); the output is the format's own
    /// (comma-separated; seconds, °/h, °C).
    #[command(flatten)]
    pub input: super::InputArgs,
    /// Output recording (CSV, written atomically).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Means over periods of this many seconds (continuous logs; 1 for the board's rate).
    #[arg(
        long,
        value_name = "S",
        default_value_t = 1.0,
        conflicts_with = "bursts"
    )]
    pub period_s: f64,
    /// One mean per burst instead (bursty logs): bursts split at steps over this many times
    /// the median step.
    #[arg(long, value_name = "FACTOR")]
    pub bursts: Option<f64>,
}

/// Runs `rlg resample`.
pub fn run(a: &ResampleArgs) -> anyhow::Result<()> {
    let rec = super::read_recording(&a.recording, &a.input)?;
    let (out, rep) = match a.bursts {
        Some(f) => burst_means(&rec, f)?,
        None => bin_means(&rec, a.period_s)?,
    };
    out.write_csv(&a.out)?;
    println!(
        "{}: {} samples → {} ({}); {} gap(s), longest {:.1} s{}",
        a.out.display(),
        rep.input_samples,
        rep.output_samples,
        if a.bursts.is_some() {
            "one per burst".to_string()
        } else {
            format!("{} s means", a.period_s)
        },
        rep.gaps,
        rep.longest_gap_s,
        if rep.dropped_columns.is_empty() {
            String::new()
        } else {
            format!("; dropped columns: {}", rep.dropped_columns.join(", "))
        }
    );
    Ok(())
}
