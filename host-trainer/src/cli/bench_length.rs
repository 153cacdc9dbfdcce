//! `rlg bench-diagnose-length`: time and peak memory of the diagnosis against the record's
//! length, on the shipped dynamic scenario repeated to N days, beside the shipped 31 h
//! record in the same run (the reference the ratios are quoted against).

use std::time::Instant;

use rlg_diagnose::{diagnose, Options, PhysicsModel};
use rlg_simulate::scenario::Segment;

/// Arguments of `rlg bench-diagnose-length`.
#[derive(Debug, clap::Args)]
pub struct BenchLengthArgs {
    /// Record lengths to diagnose, days (comma-separated).
    #[arg(long, value_name = "DAYS", value_delimiter = ',', default_value = "30")]
    pub days: Vec<f64>,
    /// Simulation seed.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Also diagnose the shipped record with its second half moved this many days later
    /// (the same samples over a longer span; 0: not run).
    #[arg(long, value_name = "DAYS", default_value_t = 30.0)]
    pub gap_days: f64,
    /// Also write the tables to this file, e.g. a results file kept in the repository, after
    /// a first line naming the command that wrote it.
    #[arg(long, value_name = "FILE")]
    pub results_md: Option<std::path::PathBuf>,
}

/// What the benchmark prints, kept for `--results-md`: each line is printed as it is
/// measured (a 30-day diagnosis takes a minute), not at the end.
#[derive(Default)]
struct Out(String);

impl Out {
    fn line(&mut self, s: &str) {
        println!("{s}");
        self.0.push_str(s);
        self.0.push('\n');
    }
}

/// The process's peak resident memory so far, MB (Linux `VmHWM`; `None` elsewhere).
fn peak_mb() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let l = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = l.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Resets the peak-memory mark to the current resident size (Linux `clear_refs` 5), so the
/// next [`peak_mb`] is the peak of what runs after it, not of the simulation before it.
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The shipped dynamic scenario with its cycle repeated to cover `days` (at least its own
/// four cycles).
fn scenario(days: f64) -> anyhow::Result<rlg_simulate::Scenario> {
    let mut s = rlg_simulate::shipped::dynamic()?;
    for seg in &mut s.profile {
        if let Segment::Repeat { count, segments } = seg {
            let cycle_s: f64 = segments
                .iter()
                .map(|g| match g {
                    Segment::Hold { duration_s } => *duration_s,
                    // 55 °C at 1 °C/min.
                    _ => 3300.0,
                })
                .sum();
            *count = ((days * 86_400.0 / cycle_s).ceil() as u32).max(*count);
        }
    }
    Ok(s)
}

/// Runs the benchmark and prints one row per length.
pub fn run(a: &BenchLengthArgs) -> anyhow::Result<()> {
    // Checked before the run, which takes minutes.
    if let Some(p) = &a.results_md {
        super::check_output_file(p, "--results-md")?;
    }
    for d in &a.days {
        anyhow::ensure!(
            d.is_finite() && *d > 0.0 && *d <= 46.0,
            "--days {d}: give lengths up to 46 days (the diagnosis' limit)"
        );
    }
    anyhow::ensure!(
        a.gap_days.is_finite() && (0.0..=3650.0).contains(&a.gap_days),
        "--gap-days {}: give a gap of 0 to 3650 days",
        a.gap_days
    );
    let mut out = Out::default();
    // The gap's rows first: after a long record the allocator keeps its pages, and the
    // resident mark of a short diagnosis would count them.
    if a.gap_days > 0.0 {
        gap_rows(a, &mut out)?;
        out.line("");
    }
    out.line(
        "| record | samples | wall s | per day, s | peak memory of the diagnosis, MB | verdict |\n|---|---:|---:|---:|---:|---|",
    );
    let mut reference: Option<f64> = None;
    let lengths = std::iter::once(None).chain(a.days.iter().map(|d| Some(*d)));
    for days in lengths {
        let sc = match days {
            None => rlg_simulate::shipped::dynamic()?,
            Some(d) => scenario(d)?,
        };
        // The simulation's own state is freed before the diagnosis is measured.
        let rec = rlg_simulate::simulate(&sc, a.seed)?.recording;
        let span_d = (rec.time_s.last().unwrap_or(&0.0) - rec.time_s[0]) / 86_400.0;
        let reset = reset_peak();
        let t0 = Instant::now();
        let samples = rec.len();
        let d = diagnose(rec, &PhysicsModel::paper(), &Options::default())?;
        let wall = t0.elapsed().as_secs_f64();
        let per_day = wall / span_d;
        let ratio = reference.map_or_else(String::new, |r| {
            format!(" ({:.2}× the 31 h record's)", per_day / r)
        });
        reference.get_or_insert(per_day);
        out.line(&format!(
            "| {} {span_d:.1} days | {} | {wall:.1} | {per_day:.2}{ratio} | {} | {} |",
            if days.is_none() {
                "shipped,"
            } else {
                "repeated,"
            },
            samples,
            match (peak_mb(), reset) {
                (Some(m), true) => format!("{m:.0}"),
                (Some(m), false) => format!("{m:.0} (with the simulation)"),
                (None, _) => "—".into(),
            },
            serde_json::to_value(d.verdict)?.as_str().unwrap_or("?")
        ));
    }
    out.line(
        "\nPeak memory is the process's resident high-water mark during the diagnosis: reset \
         before it (Linux clear_refs), so it counts the recording held and what the allocator \
         kept from the simulation, not the simulation's own peak; \"with the simulation\" where \
         the mark could not be reset. Wall times are of this machine's cores at the time; the \
         ratios in the same run are what to compare.",
    );
    if let Some(p) = &a.results_md {
        let header = super::results::header(std::env::args(), &[("--results-md", "FILE")], None);
        super::results::write(p, &header, &out.0)?;
    }
    Ok(())
}

/// One diagnosis timed and its peak memory: wall s, MB (`None` where the mark could not be
/// reset), the verdict's name.
fn timed(rec: rlg_io::recording::Recording) -> anyhow::Result<(f64, Option<f64>, String)> {
    let reset = reset_peak();
    let t0 = Instant::now();
    let d = diagnose(rec, &PhysicsModel::paper(), &Options::default())?;
    let wall = t0.elapsed().as_secs_f64();
    let verdict = serde_json::to_value(d.verdict)?
        .as_str()
        .unwrap_or("?")
        .to_string();
    Ok((wall, peak_mb().filter(|_| reset), verdict))
}

/// The shipped record, then the same samples with its second half `--gap-days` later: the
/// cost should follow the samples, not the span.
fn gap_rows(a: &BenchLengthArgs, out: &mut Out) -> anyhow::Result<()> {
    out.line(
        "| record | samples | span, days | wall s | × the record without the gap | peak memory, MB | verdict |\n|---|---:|---:|---:|---:|---:|---|",
    );
    let mut reference = None;
    for (name, gap_d) in [("shipped", 0.0), ("shipped, gap in the middle", a.gap_days)] {
        // Simulated afresh for each row, so neither holds the other's samples.
        let mut r = rlg_simulate::simulate(&rlg_simulate::shipped::dynamic()?, a.seed)?.recording;
        let half = r.len() / 2;
        r.time_s[half..]
            .iter_mut()
            .for_each(|t| *t += gap_d * 86_400.0);
        let span_d = (r.time_s.last().unwrap_or(&0.0) - r.time_s[0]) / 86_400.0;
        let samples = r.len();
        let (wall, mb, verdict) = timed(r)?;
        let ratio = reference.map_or_else(|| "1".to_string(), |w: f64| format!("{:.2}", wall / w));
        reference.get_or_insert(wall);
        out.line(&format!(
            "| {name} | {samples} | {span_d:.1} | {wall:.1} | {ratio} | {} | {verdict} |",
            mb.map_or_else(|| "—".to_string(), |m| format!("{m:.0}"))
        ));
    }
    Ok(())
}
