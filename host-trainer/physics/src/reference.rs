//! The user's reference of the term library: for every [`Mechanism`] its `kind`, what it
//! models, its equation and each parameter's TOML key, unit, meaning and default.
//!
//! [`term_doc`] matches exhaustively on [`Mechanism`], so a new mechanism does not compile
//! without its entry; the tests parse every entry's example with the real [`Term`] parser and
//! compare the documented kinds and keys with the ones that parser accepts, so the reference
//! cannot name a key the parser refuses nor miss one it accepts.

use crate::{Mechanism, Role, EARTH_RATE_DPH};

/// Symbols the equations use, with their meaning and unit.
pub const SYMBOLS: &[(&str, &str)] = &[
    (
        "b(t)",
        "the term's contribution to the gyro bias, °/h (the bias terms of a model add up)",
    ),
    (
        "T_c",
        "the body (cavity) temperature driving the model, °C: the simulator's true body \
         temperature, or the recorded temperature when a model is fitted to a recording",
    ),
    ("Ṫ_c", "dT_c/dt, °C/s"),
    ("t", "time of the recording's sample, s"),
    (
        "T_in",
        "the temperature reading before a sensor term: T_c, or the output of the sensor terms \
         listed before it (sensor terms apply in file order)",
    ),
    ("T_s", "the temperature reading after a sensor term, °C"),
];

/// One parameter of a term.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParamDoc {
    /// The TOML key.
    pub key: &'static str,
    /// Unit (`—` for a dimensionless number or a word).
    pub unit: &'static str,
    /// What the parameter is, naming its symbol in the equation.
    pub meaning: &'static str,
    /// The value taken when the key is left out, as a TOML value; `None`: the key is required.
    pub default: Option<&'static str>,
    /// A plausible value, as a TOML value (used by the examples).
    pub example: &'static str,
}

impl ParamDoc {
    /// Whether a model file must give this key.
    pub fn required(&self) -> bool {
        self.default.is_none()
    }
}

/// The reference entry of one term kind.
#[derive(Clone, Debug, PartialEq)]
pub struct TermDoc {
    /// The mechanism; its name is the `kind` in TOML.
    pub mechanism: Mechanism,
    /// What the term acts on.
    pub role: Role,
    /// The physics in one line.
    pub meaning: &'static str,
    /// The equation with the state equations of stateful terms, one per line (plain text).
    pub equation: String,
    /// Every parameter, in the order of the term's definition.
    pub params: Vec<ParamDoc>,
}

/// The driving node of the terms of a temperature that may be another node's than T_c.
const NODE_LAG: ParamDoc = p(
    "node_lag_s",
    "s",
    "Lag τ_n of the node T_n that drives the term: > 0, a node behind T_c \
     (τ_n·dT_n/dt = T_c − T_n, at rest at the first sample); < 0, a node |τ_n| ahead, \
     T_n = T_c + |τ_n|·dT_c/dt (the node a lag of |τ_n| follows); 0, T_c itself. A mechanism \
     of the laser block read by a sensor on the case, or the reverse.",
    Some("0.0"),
    "0.0",
);

const fn p(
    key: &'static str,
    unit: &'static str,
    meaning: &'static str,
    default: Option<&'static str>,
    example: &'static str,
) -> ParamDoc {
    ParamDoc {
        key,
        unit,
        meaning,
        default,
        example,
    }
}

/// A term's role, meaning, equation and parameters.
type Entry = (Role, &'static str, String, Vec<ParamDoc>);

/// The reference entry of `m`.
#[allow(
    clippy::too_many_lines,
    reason = "a table, one arm per mechanism: exhaustive, so a new mechanism does not compile \
              without its entry"
)]
pub fn term_doc(m: Mechanism) -> TermDoc {
    let (role, meaning, equation, params) = match m {
        Mechanism::EarthRate => earth_rate(),
        Mechanism::StaticPoly => static_poly(),
        Mechanism::RateTerms => rate_terms(),
        Mechanism::SensorLag => sensor_lag(),
        Mechanism::GradientLag => gradient_lag(),
        Mechanism::Hysteresis => hysteresis(),
        Mechanism::Warmup => warmup(),
        Mechanism::ModeHop => mode_hop(),
        Mechanism::Backscatter => backscatter(),
        Mechanism::Periodic => periodic(),
        Mechanism::Aging => aging(),
        Mechanism::Heteroscedastic => heteroscedastic(),
        Mechanism::TempQuantization => temp_quantization(),
    };
    TermDoc {
        mechanism: m,
        role,
        meaning,
        equation,
        params,
    }
}

fn earth_rate() -> Entry {
    (
        Role::Bias,
        "The Earth's rotation sensed by the input axis: a constant.",
        format!(
            "b(t) = ± Ω_e · sin φ,  Ω_e = {EARTH_RATE_DPH:.4} °/h\n\
             (+ for axis = \"up\", − for axis = \"down\")"
        ),
        vec![
            p(
                "latitude_deg",
                "°",
                "Latitude φ, north positive.",
                None,
                "28.2",
            ),
            p(
                "axis",
                "—",
                "Direction of the input axis along the local vertical: \"up\" or \"down\".",
                Some("\"down\""),
                "\"down\"",
            ),
        ],
    )
}

fn static_poly() -> Entry {
    (
        Role::Bias,
        "Bias as a polynomial in the body temperature (the settled temperature dependence).",
        "b(t) = Σ_k c_k · x^k,  x = (T_c − T_0) / S".into(),
        vec![
            p(
                "center_c",
                "°C",
                "Expansion centre T_0.",
                Some("0.0"),
                "0.0",
            ),
            p(
                "scale_c",
                "°C",
                "Scale S of the normalised temperature x (> 0).",
                Some("1.0"),
                "1.0",
            ),
            p(
                "coeffs_dph",
                "°/h",
                "Coefficients [c_0, c_1, …] (an array, any length; c_k in °/h per x^k).",
                None,
                "[-0.0096, 7.1445e-4, -2.6387e-5, 2.1772e-7]",
            ),
        ],
    )
}

fn rate_terms() -> Entry {
    (
        Role::Bias,
        "Bias from the rate of temperature change (the paper's Eq. (11) terms in dT/dt).",
        "b(t) = a_1 · Ṫ_c + a_3 · Ṫ_c³ + a_T · T_c · Ṫ_c".into(),
        vec![
            p(
                "linear",
                "°/h per °C/s",
                "Coefficient a_1 of Ṫ_c.",
                Some("0.0"),
                "2.1572",
            ),
            p(
                "cubic",
                "°/h per (°C/s)³",
                "Coefficient a_3 of Ṫ_c³.",
                Some("0.0"),
                "-4.2769e3",
            ),
            p(
                "temp_linear",
                "°/h per (°C · °C/s)",
                "Coefficient a_T of T_c · Ṫ_c.",
                Some("0.0"),
                "1.9163e-5",
            ),
        ],
    )
}

fn sensor_lag() -> Entry {
    (
        Role::Sensor,
        "The temperature sensor lags the body: its reading is a first-order lag.",
        "τ · dT_s/dt = T_in − T_s,  T_s(0) = T_in(0)".into(),
        vec![p(
            "tau_s",
            "s",
            "Time constant τ (≥ 0; 0: no lag).",
            None,
            "300.0",
        )],
    )
}

fn gradient_lag() -> Entry {
    (
        Role::Bias,
        "Bias from a thermal gradient across the block that follows the heating rate \
         with a lag.",
        "b(t) = g · G\n\
         τ · dG/dt = Ṫ_c − G,  G(0) = Ṫ_c(0)"
            .into(),
        vec![
            p(
                "tau_s",
                "s",
                "Time constant τ of the gradient (≥ 0; 0: G = Ṫ_c).",
                None,
                "1800.0",
            ),
            p(
                "gain",
                "°/h per °C/s",
                "Gain g of the bias on the lagged rate G.",
                None,
                "0.5",
            ),
        ],
    )
}

fn hysteresis() -> Entry {
    (
        Role::Bias,
        "Different bias on heating and cooling branches: a play (backlash) operator on \
         the body temperature.",
        "b(t) = h · (T_c − p) / (w/2)   (+h heating, −h cooling, linear in between)\n\
         p = max(T_c − w/2, min(T_c + w/2, p_prev)),  p(0) = T_c(0)\n\
         (T_n for T_c with a node lag)"
            .into(),
        vec![
            p(
                "width_c",
                "°C",
                "Full width w of the play: the reversal of T_c that takes the bias from \
                 one branch to the other (> 0).",
                None,
                "4.0",
            ),
            p(
                "height_dph",
                "°/h",
                "Half the gap h between the heating and cooling branches.",
                None,
                "0.002",
            ),
            NODE_LAG,
        ],
    )
}

fn warmup() -> Entry {
    (
        Role::Bias,
        "An exponential transient after power-on.",
        "b(t) = A · exp(−(t − t_on) / τ) for t ≥ t_on, 0 before".into(),
        vec![
            p(
                "amplitude_dph",
                "°/h",
                "Amplitude A at power-on.",
                None,
                "0.01",
            ),
            p("tau_s", "s", "Time constant τ (> 0).", None, "1800.0"),
            p(
                "t_on_s",
                "s",
                "Power-on time t_on, on the recording's time axis.",
                Some("0.0"),
                "0.0",
            ),
        ],
    )
}

fn mode_hop() -> Entry {
    (
        Role::Bias,
        "A bias step when the temperature rises past a threshold (a laser mode hop), \
         undone only below a lower one.",
        "b(t) = s while on, 0 while off\n\
         on when T_c > T_on, off when T_c < T_on − Δ, unchanged in between;\n\
         at the first sample on iff T_c > T_on\n\
         (T_n for T_c with a node lag)"
            .into(),
        vec![
            p(
                "temp_c",
                "°C",
                "Upper switching temperature T_on.",
                None,
                "40.0",
            ),
            p("step_dph", "°/h", "Bias step s.", None, "0.003"),
            p(
                "hysteresis_c",
                "°C",
                "Switching hysteresis Δ (≥ 0).",
                None,
                "2.0",
            ),
            NODE_LAG,
        ],
    )
}

fn backscatter() -> Entry {
    (
        Role::Bias,
        "A ripple periodic in temperature: lock-in/backscatter coupling changing with \
         the cavity length.",
        "b(t) = A · sin(2π · T_n / P + φ)   (T_n = T_c without a node lag)".into(),
        vec![
            p(
                "period_c",
                "°C",
                "Period P in temperature (> 0).",
                None,
                "25.0",
            ),
            p("amplitude_dph", "°/h", "Amplitude A.", None, "0.0025"),
            p("phase_rad", "rad", "Phase φ.", Some("0.0"), "0.0"),
            NODE_LAG,
        ],
    )
}

fn periodic() -> Entry {
    (
        Role::Bias,
        "A ripple periodic in time (a cyclic disturbance), optionally only inside time \
         windows.",
        "b(t) = A · sin(2π · t / P + φ) inside a window (always when none are given),\n\
         0 outside"
            .into(),
        vec![
            p("period_s", "s", "Period P (> 0).", None, "3600.0"),
            p("amplitude_dph", "°/h", "Amplitude A.", None, "0.002"),
            p("phase_rad", "rad", "Phase φ.", Some("0.0"), "0.0"),
            p(
                "windows_s",
                "s",
                "Active windows [[start, end], …], start included, end excluded; \
                 empty: always active.",
                Some("[]"),
                "[[0.0, 43200.0]]",
            ),
        ],
    )
}

fn aging() -> Entry {
    (
        Role::Bias,
        "A linear drift in time (aging of the gyro).",
        "b(t) = r · t / 86400 s".into(),
        vec![p(
            "rate_dph_per_day",
            "°/h per day",
            "Drift rate r.",
            None,
            "0.001",
        )],
    )
}

fn heteroscedastic() -> Entry {
    (
        Role::NoiseScale,
        "White noise that grows away from a temperature (scales the angle random walk's σ).",
        "σ(t) = σ_ARW · (1 + k · ((T_c − T_ref) / 30 °C)²)".into(),
        vec![
            p("k", "—", "Growth k of the noise σ.", None, "0.5"),
            p(
                "ref_c",
                "°C",
                "Temperature of least noise T_ref.",
                Some("20.0"),
                "20.0",
            ),
        ],
    )
}

fn temp_quantization() -> Entry {
    (
        Role::Sensor,
        "The temperature reading is rounded to a quantum (the sensor's resolution).",
        "T_s = q · round(T_in / q)".into(),
        vec![p("step_c", "°C", "Quantum q (> 0).", None, "0.01")],
    )
}

/// The reference of every term kind, in the library's order ([`Mechanism::ALL`]).
pub fn term_reference() -> Vec<TermDoc> {
    Mechanism::ALL.iter().map(|&m| term_doc(m)).collect()
}

/// What a term of this role acts on, in words with the unit.
pub fn role_label(role: Role) -> &'static str {
    match role {
        Role::Bias => "bias, °/h",
        Role::Sensor => "temperature reading, °C",
        Role::NoiseScale => "white-noise σ (a factor)",
    }
}

impl TermDoc {
    /// The `kind` of the term in TOML.
    pub fn kind(&self) -> &'static str {
        self.mechanism.name()
    }

    /// A `[[terms]]` table of this kind with every parameter set to its example value.
    pub fn example_toml(&self) -> String {
        let mut s = format!("[[terms]]\nkind = \"{}\"\n", self.kind());
        for q in &self.params {
            s.push_str(&format!("{} = {}\n", q.key, q.example));
        }
        s
    }

    /// [`TermDoc::example_toml`] with comments: the meaning and equation above, each
    /// parameter's unit, meaning and default beside it.
    pub fn annotated_example_toml(&self) -> String {
        let mut s = format!("# {}: {}\n", self.kind(), self.meaning);
        for line in self.equation.lines() {
            s.push_str(&format!("#   {line}\n"));
        }
        s.push_str(&format!("[[terms]]\nkind = \"{}\"\n", self.kind()));
        let lhs: Vec<String> = self
            .params
            .iter()
            .map(|q| format!("{} = {}", q.key, q.example))
            .collect();
        let w = lhs.iter().map(|l| l.chars().count()).max().unwrap_or(0);
        for (l, q) in lhs.iter().zip(&self.params) {
            let need = match q.default {
                None => "Required.".to_string(),
                Some(d) => format!("Optional, default {d}."),
            };
            let unit = match q.unit {
                "—" => String::new(),
                u => format!("[{u}] "),
            };
            let pad = " ".repeat(w - l.chars().count());
            s.push_str(&format!("{l}{pad}  # {unit}{} {need}\n", q.meaning));
        }
        s
    }

    /// This entry as Markdown: a heading, the meaning, the equation, the parameter table and
    /// the example.
    pub fn markdown(&self) -> String {
        let mut s = format!("### `{}`\n\n", self.kind());
        s.push_str(&format!(
            "Acts on the {}. {}\n\n",
            role_label(self.role),
            self.meaning
        ));
        s.push_str(&format!("```text\n{}\n```\n\n", self.equation));
        s.push_str("| key | unit | required | meaning |\n| --- | --- | --- | --- |\n");
        for q in &self.params {
            let need = match q.default {
                None => "yes".to_string(),
                Some(d) => format!("no, default `{d}`"),
            };
            s.push_str(&format!(
                "| `{}` | {} | {} | {} |\n",
                q.key,
                cell(q.unit),
                cell(&need),
                cell(q.meaning)
            ));
        }
        s.push_str(&format!("\n```toml\n{}```\n", self.example_toml()));
        s
    }
}

/// A Markdown table cell: `|` would end it.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// The whole reference as Markdown: the symbols, an index of the kinds and one section per
/// kind ([`TermDoc::markdown`]). Headings start at level 2 so that it can follow a page's
/// own title.
pub fn term_reference_markdown() -> String {
    let docs = term_reference();
    let mut s = String::from("## Symbols\n\n| symbol | meaning |\n| --- | --- |\n");
    for (sym, meaning) in SYMBOLS {
        s.push_str(&format!("| {} | {} |\n", cell(sym), cell(meaning)));
    }
    s.push_str("\n## Term kinds\n\n| kind | acts on | meaning |\n| --- | --- | --- |\n");
    for d in &docs {
        s.push_str(&format!(
            "| [`{k}`](#{k}) | {} | {} |\n",
            role_label(d.role),
            cell(d.meaning),
            k = d.kind()
        ));
    }
    for d in &docs {
        s.push('\n');
        s.push_str(&d.markdown());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Term;
    use std::collections::BTreeSet;

    #[derive(serde::Deserialize)]
    struct Terms {
        terms: Vec<Term>,
    }

    fn parse_one(text: &str) -> Result<Term, String> {
        let t: Terms = toml::from_str(text).map_err(|e| e.to_string())?;
        assert_eq!(t.terms.len(), 1, "{text}");
        Ok(t.terms.into_iter().next().expect("one term"))
    }

    /// The names a serde "unknown variant/field `x`, expected …" message offers: the
    /// back-quoted words after its last "expected".
    fn expected_names(message: &str) -> BTreeSet<String> {
        let tail = &message[message.rfind("expected").expect(message)..];
        tail.split('`')
            .skip(1)
            .step_by(2)
            .map(String::from)
            .collect()
    }

    /// A table with only the required keys, and `extra` lines appended.
    fn required_toml(d: &TermDoc, extra: &[String]) -> String {
        let mut s = format!("[[terms]]\nkind = \"{}\"\n", d.kind());
        for q in d.params.iter().filter(|q| q.required()) {
            s.push_str(&format!("{} = {}\n", q.key, q.example));
        }
        for e in extra {
            s.push_str(e);
            s.push('\n');
        }
        s
    }

    /// The documented kinds are exactly the `kind` tags the parser accepts, each once.
    #[test]
    fn every_kind_of_the_parser_is_documented_once() {
        let err = parse_one("[[terms]]\nkind = \"no_such_kind\"\n").expect_err("unknown kind");
        let parser: BTreeSet<String> = expected_names(&err);
        assert!(parser.len() > 1, "cannot read the kinds from: {err}");
        let docs = term_reference();
        let documented: BTreeSet<String> = docs.iter().map(|d| d.kind().to_string()).collect();
        assert_eq!(documented.len(), docs.len(), "a kind is documented twice");
        assert_eq!(documented, parser);
    }

    /// Each entry's example parses with every documented key, is the documented kind and
    /// role, and is valid; the keys the parser accepts are exactly the documented ones.
    #[test]
    fn every_documented_key_is_accepted_and_every_accepted_key_documented() {
        for d in term_reference() {
            for text in [d.example_toml(), d.annotated_example_toml()] {
                let t = parse_one(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", d.kind()));
                assert_eq!(t.name(), d.kind());
                assert_eq!(t.mechanism(), d.mechanism);
                assert_eq!(t.role(), d.role, "{}", d.kind());
                t.validate().unwrap_or_else(|e| panic!("{}: {e}", d.kind()));
                let keys: BTreeSet<&str> = d.params.iter().map(|q| q.key).collect();
                for (name, _) in t.parameters() {
                    let base = name.split('[').next().unwrap_or(&name);
                    assert!(keys.contains(base), "{}: `{base}` undocumented", d.kind());
                }
            }
            let err = parse_one(&required_toml(&d, &["no_such_key = 1.0".into()]))
                .expect_err("unknown key");
            let accepted = expected_names(&err);
            let documented: BTreeSet<String> = d.params.iter().map(|q| q.key.into()).collect();
            assert_eq!(accepted, documented, "{}: {err}", d.kind());
        }
    }

    /// The required keys are the ones the parser needs, and the documented defaults are the
    /// ones the parser fills in.
    #[test]
    fn required_flags_and_defaults_match_the_parser() {
        for d in term_reference() {
            let bare = parse_one(&required_toml(&d, &[]))
                .unwrap_or_else(|e| panic!("{}: only the required keys: {e}", d.kind()));
            let defaults: Vec<String> = d
                .params
                .iter()
                .filter_map(|q| q.default.map(|v| format!("{} = {v}", q.key)))
                .collect();
            let explicit = parse_one(&required_toml(&d, &defaults)).expect("defaults parse");
            assert_eq!(bare, explicit, "{}: documented defaults differ", d.kind());
            for q in d.params.iter().filter(|q| q.required()) {
                let text: String = required_toml(&d, &[])
                    .lines()
                    .filter(|l| !l.starts_with(&format!("{} =", q.key)))
                    .map(|l| format!("{l}\n"))
                    .collect();
                let err = parse_one(&text).expect_err(q.key);
                assert!(
                    err.contains(&format!("missing field `{}`", q.key)),
                    "{}: {err}",
                    d.kind()
                );
            }
        }
    }

    /// Every entry is filled in and every kind has its section in the Markdown.
    #[test]
    fn entries_are_complete() {
        for d in term_reference() {
            assert!(
                !d.meaning.is_empty() && !d.equation.is_empty(),
                "{}",
                d.kind()
            );
            for q in &d.params {
                assert!(!q.unit.is_empty() && !q.meaning.is_empty(), "{}", q.key);
            }
        }
        let md = term_reference_markdown();
        for m in Mechanism::ALL {
            assert!(md.contains(&format!("### `{}`", m.name())), "{m}");
        }
    }
}
