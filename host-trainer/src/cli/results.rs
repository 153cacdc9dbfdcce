//! Results files (`--results-md FILE`): a command's Markdown report kept in the repository
//! (`host-trainer/results/`), its first line naming the command that wrote it.

use std::path::Path;

use anyhow::Context as _;

/// The first line of a results file: "Written by `rlg …`." with the command as typed (`args`,
/// the program's own path dropped), the values of the file and folder flags in `paths` (flag,
/// placeholder) shown as their placeholders so that no path of the machine that ran it is
/// kept, and `note` in brackets after it.
pub fn header<I: IntoIterator<Item = String>>(
    args: I,
    paths: &[(&str, &str)],
    note: Option<&str>,
) -> String {
    let placeholder = |flag: &str| paths.iter().find(|(f, _)| *f == flag).map(|(_, p)| *p);
    let mut line = String::from("rlg");
    let mut next_is_path = None;
    for a in args.into_iter().skip(1) {
        let word = if let Some(p) = next_is_path.take() {
            String::from(p)
        } else if let Some((flag, p)) = a
            .split_once('=')
            .and_then(|(f, _)| placeholder(f).map(|p| (f, p)))
        {
            format!("{flag}={p}")
        } else {
            next_is_path = placeholder(&a);
            a
        };
        line.push(' ');
        if word.is_empty() || word.contains(char::is_whitespace) {
            line.push_str(&format!("{word:?}"));
        } else {
            line.push_str(&word);
        }
    }
    match note {
        Some(n) => format!("Written by `{line}` ({n})."),
        None => format!("Written by `{line}`."),
    }
}

/// Writes `header`, a blank line and `md` to `path` (atomically).
pub fn write(path: &Path, header: &str, md: &str) -> anyhow::Result<()> {
    rlg_io::atomic::write(path, format!("{header}\n\n{md}").as_bytes())
        .with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_names_the_command_without_its_paths() {
        let args = [
            "/x/target/release/rlg",
            "benchmark-diagnose",
            "--seed",
            "2",
            "--out",
            "/tmp/my run",
            "--results-md=host-trainer/results/diagnose-benchmark.md",
            "--quick",
        ]
        .map(String::from);
        assert_eq!(
            header(
                args,
                &[("--out", "DIR"), ("--results-md", "FILE")],
                Some("quick set")
            ),
            "Written by `rlg benchmark-diagnose --seed 2 --out DIR --results-md=FILE --quick` \
             (quick set)."
        );
    }

    #[test]
    fn the_file_is_the_header_then_the_report() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let p = dir.path().join("r.md");
        write(&p, "Written by `rlg x`.", "# R\n").expect("writes");
        assert_eq!(
            std::fs::read_to_string(&p).expect("reads"),
            "Written by `rlg x`.\n\n# R\n"
        );
    }
}
