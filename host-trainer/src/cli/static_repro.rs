//! `rlg static-repro`: the paper's static model (Table 1, Fig. 2(a)) reproduced.

use anyhow::Context;
use rlg_eval::baselines::static_polynomial;
use rlg_eval::metrics::compare::{markdown_table, FigureOfMerit};
use rlg_io::{plot, table1};
use std::path::PathBuf;

/// Arguments of `rlg static-repro`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Table 1 CSV (default: the copy bundled with the crate).
    #[arg(long)]
    pub table: Option<PathBuf>,
    /// Degree of the least-squares polynomial (2: the paper's quadratic).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u64).range(1..=6))]
    pub degree: u64,
    /// Write a Fig. 2(a)-style PNG here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// Fits the quadratic, prints coefficients, the per-point table and a summary.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let rows = match &args.table {
        Some(p) => table1::read_table1(p)?,
        None => table1::bundled().context("bundled Table 1")?,
    };
    let degree = args.degree as usize;
    let r = static_polynomial(&rows, degree).context("fitting the polynomial")?;
    let (c, se) = (r.fit.coefficients(), r.fit.std_errors());
    println!(
        "Least-squares polynomial of degree {degree}, output (°/h) on body temperature T (°C):"
    );
    println!("  rate_dph = Σ a_k·T^k");
    for k in 0..=degree {
        println!("  a{k} = {:+.6e} ± {:.2e} °/h/°C^{k}", c[k], se[k]);
    }
    println!(
        "  residual σ = {:.2e} °/h (n − {} = {} dof)\n",
        r.fit.sigma(),
        degree + 1,
        rows.len().saturating_sub(degree + 1)
    );
    if degree != 2 {
        println!("(The paper's error column belongs to its quadratic, shown for comparison.)\n");
    }
    println!("Errors are prediction − measurement. TRAINING: fit to all points (what the paper");
    println!("quotes). LOO: the point's error when the polynomial is refitted without it.\n");
    print!("{}", r.to_markdown());
    let paper_max = rows
        .iter()
        .map(|p| p.quad_err_1e4_dph.abs() * 1e-4)
        .fold(0.0, f64::max);
    println!();
    print!(
        "{}",
        markdown_table(&[
            FigureOfMerit::new(
                "max |training error|",
                "°/h",
                r.max_abs_train_err_dph(),
                Some(paper_max)
            ),
            FigureOfMerit::new("max |LOO error|", "°/h", r.max_abs_loo_err_dph(), None),
            FigureOfMerit::new(
                "max |ours − paper|, training errors",
                "°/h",
                r.max_abs_diff_from_paper_dph(),
                None
            ),
        ])
    );
    if let Some(p) = &args.plot {
        plot::render_png(&r.figure(), p).with_context(|| format!("writing {}", p.display()))?;
        println!("\nwrote {}", p.display());
    }
    Ok(())
}
