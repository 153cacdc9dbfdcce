//! `rlg terms`: the physics terms a model file can use, printed from the term library's own
//! reference ([`rlg_physics::reference`]), so that the help cannot drift from the parser.

use rlg_physics::reference::{role_label, term_doc, term_reference, TermDoc, SYMBOLS};
use rlg_physics::{term_reference_markdown, Mechanism};

/// Arguments of `rlg terms`.
#[derive(Debug, clap::Args)]
pub struct TermsArgs {
    /// Print the reference as Markdown: the page host-trainer/models/TERMS.md (the file
    /// format, then every term).
    #[arg(long, conflicts_with = "example")]
    pub markdown: bool,
    /// Print a valid `[[terms]]` TOML snippet of this kind, each parameter explained beside it.
    #[arg(
        long,
        value_name = "KIND",
        value_parser = clap::builder::PossibleValuesParser::new(
            Mechanism::ALL.iter().map(|m| m.name())
        )
    )]
    pub example: Option<String>,
}

/// Runs `rlg terms`.
pub fn run(args: &TermsArgs) -> anyhow::Result<()> {
    if let Some(kind) = &args.example {
        let m: Mechanism = kind.parse()?;
        print!("{}", term_doc(m).annotated_example_toml());
    } else if args.markdown {
        print!("{}", page_markdown());
    } else {
        print!("{}", text());
    }
    Ok(())
}

/// The page's introduction to the file format, before the generated reference.
const HEADER: &str = "\
# Physics model files

<!-- This page is the output of
`cargo run -p host-trainer --bin rlg -- terms --markdown > host-trainer/models/TERMS.md`:
change the term reference (host-trainer/physics/src/reference.rs) or this header
(host-trainer/src/cli/terms.rs) and regenerate it; a test fails while it is stale. -->

A physics model file is a TOML file listing the effects that make up a ring-laser gyro's
bias, and those that act on its temperature reading and its noise, each with its
parameters. `rlg diagnose --model FILE` fits the model's linear parameters to a recording
and looks for the effect the model lacks; without `--model` it uses
`host-trainer/models/paper.toml` (Yu et al. 2011, Eq. (11)). `rlg terms` prints this
reference in the terminal, `rlg terms --example KIND` a snippet to start from.

## Format

* `name = \"…\"` (optional): a short name.
* One `[[terms]]` table per term: `kind = \"…\"` picks the term (one of the kinds below),
  the other keys are its parameters. A required key left out, a key the kind does not
  have, or an unknown top-level key is an error that names the key.
* Bias terms add up; sensor terms transform the temperature reading in the order of the
  file; noise terms multiply the white noise's σ.
* Units are fixed and the key's suffix names them: `_c` °C, `_s` s, `_dph` °/h,
  `_dph_per_day` °/h per day, `_deg` degrees, `_rad` radians. Rate coefficients are per
  °C/s of the temperature's rate of change; times are on the recording's time axis.

Example: the paper's model with a sensor that reads the body temperature 300 s late.

```toml
";

/// The example model of the header; a test parses it.
const EXAMPLE_MODEL: &str = "\
name = \"paper-with-sensor-lag\"

# The Earth's rotation, input axis pointing down at 28.2 °N.
[[terms]]
kind = \"earth_rate\"
latitude_deg = 28.2

# The settled temperature dependence: a cubic in T_c (°C), °/h.
[[terms]]
kind = \"static_poly\"
coeffs_dph = [-0.00960, 7.1445e-4, -2.6387e-5, 2.1772e-7]

# Eq. (11)'s terms in the rate of temperature change (°C/s).
[[terms]]
kind = \"rate_terms\"
linear = 2.1572
cubic = -4.2769e3
temp_linear = 1.9163e-5

# The temperature sensor lags the body.
[[terms]]
kind = \"sensor_lag\"
tau_s = 300.0
";

/// The header's part after the example.
const HEADER_END: &str = "\
```

## Scenario files

A scenario file (the input of `rlg simulate`, e.g.
`host-trainer/scenarios/yu2011-dynamic.toml`) is accepted as a model file too: its `name`
and `[[terms]]` are read and its other keys (`thermal`, `profile`, `noise`, …) are ignored,
so `rlg diagnose --model host-trainer/scenarios/yu2011-dynamic.toml` checks a recording
against the physics it was simulated with.

";

/// The Markdown page `host-trainer/models/TERMS.md`: the file format, then
/// [`term_reference_markdown`].
pub fn page_markdown() -> String {
    format!(
        "{HEADER}{EXAMPLE_MODEL}{HEADER_END}{}",
        term_reference_markdown()
    )
}

/// The reference as plain text for the terminal.
pub fn text() -> String {
    let mut s = String::from(
        "Physics terms of a model file: one [[terms]] table per term, kind = \"<kind>\" and its\n\
         parameters (units fixed, named by the key's suffix). A scenario file's [[terms]] are\n\
         accepted too. `rlg terms --example KIND` prints a snippet, `--markdown` the page\n\
         host-trainer/models/TERMS.md.\n\nSymbols:\n",
    );
    let w = SYMBOLS.iter().map(|(k, _)| width(k)).max().unwrap_or(0);
    for (sym, meaning) in SYMBOLS {
        s.push_str(&wrap(&format!("  {}  ", pad(sym, w)), meaning));
    }
    for d in term_reference() {
        s.push('\n');
        s.push_str(&term_text(&d));
    }
    s
}

/// One term's entry: kind and role, meaning, equation, one line per parameter.
fn term_text(d: &TermDoc) -> String {
    let mut s = format!("{} — acts on the {}\n", d.kind(), role_label(d.role));
    s.push_str(&wrap("  ", d.meaning));
    for line in d.equation.lines() {
        s.push_str(&format!("      {line}\n"));
    }
    let need: Vec<String> = d
        .params
        .iter()
        .map(|q| match q.default {
            None => "required".to_string(),
            Some(v) => format!("default {v}"),
        })
        .collect();
    let wk = d.params.iter().map(|q| width(q.key)).max().unwrap_or(0);
    let wu = d.params.iter().map(|q| width(q.unit)).max().unwrap_or(0);
    let wn = need.iter().map(|n| width(n)).max().unwrap_or(0);
    for (q, n) in d.params.iter().zip(&need) {
        let lead = format!(
            "  {}  {}  {}  ",
            pad(q.key, wk),
            pad(q.unit, wu),
            pad(n, wn)
        );
        s.push_str(&wrap(&lead, q.meaning));
    }
    s
}

/// Columns of the terminal text.
const TEXT_WIDTH: usize = 96;

/// `lead` then `text` filled to [`TEXT_WIDTH`], the following lines indented as wide as
/// `lead`; ends with a newline.
fn wrap(lead: &str, text: &str) -> String {
    let indent = " ".repeat(width(lead));
    let mut out = lead.to_string();
    let mut col = width(lead);
    let mut first = true;
    for word in text.split_whitespace() {
        if !first && col + 1 + width(word) > TEXT_WIDTH {
            out.push('\n');
            out.push_str(&indent);
            col = width(&indent);
        } else if !first {
            out.push(' ');
            col += 1;
        }
        out.push_str(word);
        col += width(word);
        first = false;
    }
    out.push('\n');
    out
}

/// Width in characters (the units hold `°`, `³`, `—`: one column each, several bytes).
fn width(s: &str) -> usize {
    s.chars().count()
}

fn pad(s: &str, w: usize) -> String {
    format!("{s}{}", " ".repeat(w.saturating_sub(width(s))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::{Cli, Command};
    use clap::Parser as _;

    /// The committed page is what `rlg terms --markdown` prints.
    #[test]
    fn committed_page_is_current() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/TERMS.md");
        let committed = std::fs::read_to_string(path).unwrap_or_default();
        let now = page_markdown();
        let first_difference = committed
            .lines()
            .zip(now.lines())
            .position(|(a, b)| a != b)
            .map_or(String::from("length differs"), |i| {
                format!("first difference at line {}", i + 1)
            });
        assert!(
            committed == now,
            "host-trainer/models/TERMS.md is stale ({first_difference}); regenerate it from the \
             workspace root with \
             `cargo run -p host-trainer --bin rlg -- terms --markdown > host-trainer/models/TERMS.md`"
        );
    }

    /// The page's example is a valid model.
    #[test]
    fn example_model_is_valid() {
        let m = rlg_diagnose::PhysicsModel::from_toml(EXAMPLE_MODEL, "example").expect("valid");
        assert_eq!(m.terms.len(), 4);
    }

    /// The text names every kind; `--example` takes exactly the kinds and conflicts with
    /// `--markdown`.
    #[test]
    fn text_and_arguments_cover_every_kind() {
        let t = text();
        for m in Mechanism::ALL {
            assert!(t.contains(&format!("\n{} — acts on", m.name())), "{m}");
            let cli = Cli::try_parse_from(["rlg", "terms", "--example", m.name()]).expect("kind");
            match cli.command {
                Command::Terms(a) => assert_eq!(a.example.as_deref(), Some(m.name())),
                other => panic!("{other:?}"),
            }
        }
        assert!(Cli::try_parse_from(["rlg", "terms", "--example", "lock_in"]).is_err());
        assert!(Cli::try_parse_from(["rlg", "terms", "--markdown", "--example", "aging"]).is_err());
    }
}
