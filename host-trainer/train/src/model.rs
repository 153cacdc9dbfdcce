//! The trained-model file: versioned JSON holding everything needed to evaluate, audit and
//! export a model.
//!
//! Written atomically (temporary file in the same folder, then renamed), read back with a
//! check of `format_version` before anything else is interpreted.

use std::path::Path;

use compensator_core::Feature;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::features::RowSet;
use crate::lssvm::{self, Lssvm, LssvmError};

/// The only model-file layout this build reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// The reference temperature of `reference_dph`, °C (clamped into the trained range).
pub const REFERENCE_TEMP_C: f64 = 25.0;

/// Why a model could not be built, read or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    /// Training failed.
    #[error(transparent)]
    Lssvm(#[from] LssvmError),
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file is not valid model JSON.
    #[error("{path}: not a model file: {message}")]
    Format {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// The file has another `format_version`.
    #[error("{path}: model format_version {found} is not supported (this build reads version {FORMAT_VERSION}); retrain or export with a matching build")]
    Version {
        /// The file.
        path: String,
        /// The version found.
        found: u64,
    },
    /// The content is inconsistent (lengths, unknown feature, non-finite number).
    #[error("inconsistent model: {0}")]
    Invalid(String),
}

/// Where a model came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// The training data file's name (no folder).
    pub data_file: String,
    /// SHA-256 of the data file's bytes, lower-case hex.
    pub data_sha256: String,
    /// Size of the data file, bytes.
    pub data_len_bytes: u64,
    /// The command line that trained the model.
    pub command: String,
}

impl Provenance {
    /// Provenance of a model trained from the bytes of a file named `data_file`.
    pub fn from_bytes(data_file: &str, bytes: &[u8], command: &str) -> Provenance {
        Provenance {
            data_file: data_file.to_string(),
            data_sha256: format!("{:x}", Sha256::digest(bytes)),
            data_len_bytes: bytes.len() as u64,
            command: command.to_string(),
        }
    }

    /// Provenance of a model trained from the file at `path` (only its name is kept).
    /// The file is hashed as it is read, never held whole: a 10⁷-sample recording is 440 MB.
    pub fn from_file(path: &Path, command: &str) -> Result<Provenance, ModelError> {
        use std::io::Read;
        let io = |source| ModelError::Io {
            path: path.display().to_string(),
            source,
        };
        let mut file = std::fs::File::open(path).map_err(io)?;
        let mut hasher = Sha256::new();
        let mut buf = vec![0u8; 1 << 16];
        let mut len = 0u64;
        loop {
            match file.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => {
                    hasher.update(&buf[..n]);
                    len += n as u64;
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(io(e)),
            }
        }
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        Ok(Provenance {
            data_file: name,
            data_sha256: format!("{:x}", hasher.finalize()),
            data_len_bytes: len,
            command: command.to_string(),
        })
    }
}

/// Fit quality on the training set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainingSummary {
    /// Training samples (after any block averaging).
    pub samples: usize,
    /// RMS of the training residuals f(x_i) − y_i, °/h. A TRAINING error, not a test error.
    pub rms_dph: f64,
    /// Largest |f(x_i) − y_i| on the training set, °/h.
    pub max_abs_dph: f64,
    /// RMS of the leave-one-out residuals (PRESS), °/h, when computed.
    pub loo_rms_dph: Option<f64>,
}

/// A trained model with everything the board and an auditor need.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelFile {
    /// Always [`FORMAT_VERSION`].
    pub format_version: u32,
    /// The regression: feature names, standardisation, support vectors, a, b, σ, c.
    pub lssvm: Lssvm,
    /// Smallest value of each feature the model was fitted on, raw unit.
    pub input_lo: Vec<f64>,
    /// Largest value of each feature the model was fitted on, raw unit.
    pub input_hi: Vec<f64>,
    /// The reference condition (raw features): T = 25 °C and dT/dt = 0, clamped into range.
    pub reference_input: Vec<f64>,
    /// f(reference_input), °/h. The board outputs raw − (f(x) − reference_dph).
    pub reference_dph: f64,
    /// Time constant of the dT/dt estimator used for the features, s.
    pub rate_tau_s: f64,
    /// Sample period the estimator runs at, s.
    pub dt_s: f64,
    /// Fit quality on the training set.
    pub training: TrainingSummary,
    /// Where the model came from.
    pub provenance: Provenance,
    /// The board's f32 departure this table is held to when the record's noise and the
    /// model's CV error allow a coarser one than [`crate::export::EXPORT_LIMIT_DPH`] (a MEMS
    /// gyro's), °/h; absent: the export's own limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub f32_limit_dph: Option<f64>,
    /// What the board removes: only the variation about `reference_dph` (absent, the
    /// default) or the whole bias.
    #[serde(default, skip_serializing_if = "Removal::is_variation")]
    pub removes: Removal,
}

/// What the board removes from the raw rate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Removal {
    /// f(x) − f(reference): the output keeps the bias at the reference condition. An RLG's
    /// constant holds the Earth rate and is calibrated at each start; only the temperature
    /// variation belongs in a table.
    #[default]
    Variation,
    /// f(x): the output is centred on zero. A MEMS gyro's turn-on bias of thousands of °/h
    /// dominates, and the table is the only place that knows it.
    Whole,
}

impl Removal {
    /// Whether only the variation is removed (the model file then does not name it).
    pub fn is_variation(&self) -> bool {
        *self == Self::Variation
    }

    /// How the report says it.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Variation => "only the bias' variation about its value at the reference",
            Self::Whole => "the whole bias",
        }
    }
}

/// The reference condition for `features`: temperatures (T, lead-corrected T, play state) at
/// [`REFERENCE_TEMP_C`], rates (dT/dt, lagged gradient) 0, warmed up (time since power-on at
/// its largest trained value, warm-up decay 0), each clamped into `[lo, hi]`.
pub fn reference_input(features: &[String], lo: &[f64], hi: &[f64]) -> Vec<f64> {
    features
        .iter()
        .zip(lo.iter().zip(hi))
        .map(|(f, (l, h))| {
            let v = match Feature::from_name(f) {
                Some(Feature::TempC | Feature::TempLeadC { .. } | Feature::TempPlayC { .. }) => {
                    REFERENCE_TEMP_C
                }
                Some(Feature::TimeOnS) => *h,
                _ => 0.0,
            };
            v.clamp(*l, *h)
        })
        .collect()
}

impl ModelFile {
    /// Trains on raw inputs `x` (columns named by `features`) and targets `y_dph`, and fills in
    /// range, reference, training errors (and LOO residuals when `with_loo`).
    #[allow(clippy::too_many_arguments)]
    pub fn train(
        features: &[String],
        x: &[Vec<f64>],
        y_dph: &[f64],
        sigma: f64,
        c: f64,
        rate_tau_s: f64,
        dt_s: f64,
        with_loo: bool,
        provenance: Provenance,
    ) -> Result<ModelFile, ModelError> {
        for f in features {
            if Feature::from_name(f).is_none() {
                return Err(ModelError::Invalid(format!("unknown feature {f:?}")));
            }
        }
        let model = Lssvm::train(features, x, y_dph, sigma, c)?;
        let loo_rms_dph = if with_loo {
            let r = lssvm::loo_residuals(&model.support, y_dph, sigma, c)?;
            Some(rms(&r))
        } else {
            None
        };
        ModelFile::from_trained(model, x, y_dph, rate_tau_s, dt_s, loo_rms_dph, provenance)
    }

    /// Wraps an already trained regression (for example a reduced one, see
    /// [`crate::lssvm::sparse`]) with range, reference and training errors on its training
    /// set `x`, `y_dph` (raw features, °/h).
    pub fn from_trained<X: RowSet + ?Sized>(
        model: Lssvm,
        x: &X,
        y_dph: &[f64],
        rate_tau_s: f64,
        dt_s: f64,
        loo_rms_dph: Option<f64>,
        provenance: Provenance,
    ) -> Result<ModelFile, ModelError> {
        let features = model.features.clone();
        let n = x.n_rows();
        if n == 0 || n != y_dph.len() {
            return Err(ModelError::Invalid(format!(
                "{n} training rows but {} targets",
                y_dph.len()
            )));
        }
        let rows = || (0..n).map(|i| x.row(i));
        let resid: Vec<f64> = rows()
            .zip(y_dph)
            .map(|(r, y)| model.predict(r) - y)
            .collect();
        let training = TrainingSummary {
            samples: n,
            rms_dph: rms(&resid),
            max_abs_dph: resid.iter().fold(0.0, |m, v| f64::max(m, v.abs())),
            loo_rms_dph,
        };
        let dim = features.len();
        let input_lo: Vec<f64> = (0..dim)
            .map(|d| rows().map(|r| r[d]).fold(f64::INFINITY, f64::min))
            .collect();
        let input_hi: Vec<f64> = (0..dim)
            .map(|d| rows().map(|r| r[d]).fold(f64::NEG_INFINITY, f64::max))
            .collect();
        let reference_input = reference_input(&features, &input_lo, &input_hi);
        let reference_dph = model.predict(&reference_input);
        let m = ModelFile {
            format_version: FORMAT_VERSION,
            lssvm: model,
            input_lo,
            input_hi,
            reference_input,
            reference_dph,
            rate_tau_s,
            dt_s,
            training,
            provenance,
            f32_limit_dph: None,
            removes: Removal::Variation,
        };
        m.validate()?;
        Ok(m)
    }

    /// Eq. (10) at a raw feature vector, °/h.
    pub fn predict_dph(&self, x: &[f64]) -> f64 {
        self.lssvm.predict(x)
    }

    /// The correction the board subtracts, °/h (no clamping): f(x) − reference_dph, or f(x)
    /// where the board removes the whole bias.
    pub fn correction_dph(&self, x: &[f64]) -> f64 {
        self.predict_dph(x) - self.kept_dph()
    }

    /// The constant the board's output keeps, °/h: `reference_dph`, or 0 where the board
    /// removes the whole bias.
    pub fn kept_dph(&self) -> f64 {
        match self.removes {
            Removal::Variation => self.reference_dph,
            Removal::Whole => 0.0,
        }
    }

    /// Checks shapes, feature names and finiteness.
    pub fn validate(&self) -> Result<(), ModelError> {
        let m = &self.lssvm;
        let dim = m.features.len();
        let bad = |s: String| Err(ModelError::Invalid(s));
        if self.format_version != FORMAT_VERSION {
            return bad(format!(
                "format_version {} (want {FORMAT_VERSION})",
                self.format_version
            ));
        }
        if dim == 0 {
            return bad("no features".into());
        }
        if let Some(l) = self.f32_limit_dph.filter(|l| !(l.is_finite() && *l > 0.0)) {
            return bad(format!("f32_limit_dph {l} (want a positive number of °/h)"));
        }
        if let Some(f) = m.features.iter().find(|f| Feature::from_name(f).is_none()) {
            return bad(format!("unknown feature {f:?}"));
        }
        let lens = [
            m.scaling.mean.len(),
            m.scaling.scale.len(),
            self.input_lo.len(),
            self.input_hi.len(),
            self.reference_input.len(),
        ];
        if lens.iter().any(|l| *l != dim) || m.support.iter().any(|s| s.len() != dim) {
            return bad(format!("per-feature vectors do not all have {dim} entries"));
        }
        if m.support.is_empty() || m.support.len() != m.alpha_dph.len() {
            return bad(format!(
                "{} support vectors but {} coefficients",
                m.support.len(),
                m.alpha_dph.len()
            ));
        }
        let scalars = [
            m.bias_dph,
            m.sigma,
            m.c,
            self.reference_dph,
            self.rate_tau_s,
            self.dt_s,
        ];
        let finite = scalars.iter().all(|v| v.is_finite())
            && m.alpha_dph
                .iter()
                .chain(m.support.iter().flatten())
                .all(|v| v.is_finite())
            && m.scaling
                .mean
                .iter()
                .chain(&m.scaling.scale)
                .all(|v| v.is_finite())
            && self
                .input_lo
                .iter()
                .chain(&self.input_hi)
                .all(|v| v.is_finite());
        if !finite {
            return bad("a stored number is NaN or infinite".into());
        }
        if !(m.sigma > 0.0 && m.c > 0.0 && self.rate_tau_s > 0.0 && self.dt_s > 0.0)
            || m.scaling.scale.iter().any(|s| *s <= 0.0)
        {
            return bad("sigma, c, rate_tau_s, dt_s and every scale must be positive".into());
        }
        if self.input_lo.iter().zip(&self.input_hi).any(|(l, h)| l > h) {
            return bad("an input range has lo > hi".into());
        }
        Ok(())
    }

    /// Pretty JSON text of the model.
    pub fn to_json(&self) -> String {
        // Serialising plain structs of numbers and strings cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default() + "\n"
    }

    /// Parses model JSON; `path` only labels errors. The version is checked first.
    pub fn from_json(text: &str, path: &str) -> Result<ModelFile, ModelError> {
        let fmt = |e: serde_json::Error| ModelError::Format {
            path: path.to_string(),
            message: e.to_string(),
        };
        let value: serde_json::Value = serde_json::from_str(text).map_err(fmt)?;
        match value
            .get("format_version")
            .and_then(serde_json::Value::as_u64)
        {
            Some(v) if v == u64::from(FORMAT_VERSION) => {}
            Some(found) => {
                return Err(ModelError::Version {
                    path: path.to_string(),
                    found,
                })
            }
            None => {
                return Err(ModelError::Format {
                    path: path.to_string(),
                    message: "no integer field format_version".into(),
                })
            }
        }
        // From the text again, not from `value`: serde_json then says where (line, column) a
        // field is missing or of the wrong type.
        let m: ModelFile = serde_json::from_str(text).map_err(fmt)?;
        m.validate()?;
        Ok(m)
    }

    /// Reads and validates a model file.
    pub fn read(path: &Path) -> Result<ModelFile, ModelError> {
        let text = std::fs::read_to_string(path).map_err(|source| ModelError::Io {
            path: path.display().to_string(),
            source,
        })?;
        ModelFile::from_json(&text, &path.display().to_string())
    }

    /// Writes the model atomically.
    pub fn write(&self, path: &Path) -> Result<(), ModelError> {
        write_atomic(path, self.to_json().as_bytes())
    }
}

/// Writes `bytes` to `path` atomically ([`rlg_io::atomic::write`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ModelError> {
    rlg_io::atomic::write(path, bytes).map_err(|source| ModelError::Io {
        path: path.display().to_string(),
        source,
    })
}

fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The file hashed as it is read gives the provenance of its bytes held whole, across
    /// several read buffers.
    #[test]
    fn provenance_of_a_file_is_that_of_its_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rec.csv");
        let bytes: Vec<u8> = (0..200_003u32).map(|i| (i * 7 % 251) as u8).collect();
        std::fs::write(&path, &bytes).unwrap();
        let p = Provenance::from_file(&path, "rlg train").unwrap();
        assert_eq!(p, Provenance::from_bytes("rec.csv", &bytes, "rlg train"));
        assert_eq!(p.data_len_bytes, 200_003);
    }

    fn tiny() -> ModelFile {
        let names = vec!["temp_c".to_string()];
        let x: Vec<Vec<f64>> = (0..12).map(|i| vec![-30.0 + 8.0 * i as f64]).collect();
        let y: Vec<f64> = x
            .iter()
            .map(|r| -7.1 - 3e-4 * r[0] + 2e-6 * r[0] * r[0])
            .collect();
        let prov = Provenance::from_bytes("t.csv", b"abc", "rlg train");
        ModelFile::train(&names, &x, &y, 1.0, 1e4, 60.0, 1.0, true, prov).unwrap()
    }

    #[test]
    fn sha256_matches_the_published_test_vector() {
        let p = Provenance::from_bytes("t.csv", b"abc", "x");
        assert_eq!(
            p.data_sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(p.data_len_bytes, 3);
    }

    #[test]
    fn json_round_trip_is_exact_and_versions_are_checked() {
        let m = tiny();
        let back = ModelFile::from_json(&m.to_json(), "m.json").unwrap();
        assert_eq!(back, m);
        let other = m
            .to_json()
            .replacen("\"format_version\": 1", "\"format_version\": 2", 1);
        let e = ModelFile::from_json(&other, "m.json").unwrap_err();
        assert!(matches!(e, ModelError::Version { found: 2, .. }), "{e}");
        assert!(e.to_string().contains("format_version 2"), "{e}");
        assert!(ModelFile::from_json("{}", "m.json").is_err());
    }

    /// A structurally wrong model file names the file, the field and where it is.
    #[test]
    fn format_errors_say_where() {
        let e = ModelFile::from_json(
            "{\"format_version\": 1,\n \"features\": [1, 2]\n}\n",
            "m.json",
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("m.json: not a model file: "), "{e}");
        // serde reports a missing field where the object ends.
        assert!(
            e.contains("missing field") && e.contains("line 3 column 1"),
            "{e}"
        );
        let m = tiny().to_json();
        let bad = m.replacen("\"sigma\": 1.0", "\"sigma\": \"wide\"", 1);
        assert_ne!(bad, m, "the edit must apply");
        let line = 1 + bad[..bad.find("\"wide\"").unwrap()].matches('\n').count();
        let e = ModelFile::from_json(&bad, "m.json")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("invalid type") && e.contains(&format!("line {line} column")),
            "{e}"
        );
    }

    #[test]
    fn reference_is_the_prediction_at_25_c() {
        let m = tiny();
        assert_eq!(m.reference_input, vec![25.0]);
        assert_eq!(m.reference_dph, m.predict_dph(&[25.0]));
        assert_eq!(m.correction_dph(&[25.0]), 0.0);
        assert_eq!((m.input_lo[0], m.input_hi[0]), (-30.0, 58.0));
        // Clamping: a range above 25 °C and a dT/dt range not containing 0.
        let f = ["temp_c".to_string(), "temp_rate_c_per_s".to_string()];
        assert_eq!(
            reference_input(&f, &[30.0, 0.01], &[60.0, 0.02]),
            vec![30.0, 0.01]
        );
    }

    #[test]
    fn atomic_write_then_read() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.json");
        let m = tiny();
        m.write(&p).unwrap();
        m.write(&p).unwrap(); // overwriting works too
        assert_eq!(ModelFile::read(&p).unwrap(), m);
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temporary file left behind"
        );
    }
}

/// Numerical edge cases of training and export: each gives a clear error or a model whose
/// exported table holds only finite numbers (the exporter's own checks then decide).
#[cfg(test)]
mod edge_cases {
    use super::*;

    fn names() -> Vec<String> {
        vec!["temp_c".into(), "temp_rate_c_per_s".into()]
    }

    fn data(n: usize) -> (Vec<Vec<f64>>, Vec<f64>) {
        let x: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let t = i as f64;
                vec![
                    10.0 + 55.0 * (t * 0.618_033_988_7).fract(),
                    0.02 * ((t * 0.414_213_562_4).fract() - 0.5),
                ]
            })
            .collect();
        let y = x.iter().map(|r| -7.1 - 2e-4 * r[0] + 0.4 * r[1]).collect();
        (x, y)
    }

    fn train(x: &[Vec<f64>], y: &[f64], sigma: f64, c: f64) -> Result<ModelFile, ModelError> {
        let prov = Provenance::from_bytes("edge", b"", "edge-case test");
        ModelFile::train(&names(), x, y, sigma, c, 60.0, 1.0, false, prov)
    }

    /// A trained model either exports a table of finite numbers or is refused by the
    /// exporter with a reason; nothing non-finite reaches a table.
    fn exports_finite_or_refuses(m: &ModelFile, what: &str) {
        match crate::export::to_f32::<2>(m) {
            Ok(t) => {
                let finite = t
                    .support
                    .iter()
                    .flatten()
                    .chain(&t.alpha_dph)
                    .all(|v| v.is_finite())
                    && t.spec.bias_dph.is_finite()
                    && t.spec.gamma.is_finite()
                    && t.spec.gamma > 0.0;
                assert!(finite, "{what}: non-finite table");
            }
            Err(e) => assert!(!e.to_string().is_empty(), "{what}"),
        }
    }

    #[test]
    fn extreme_hyper_parameters() {
        let (x, y) = data(60);
        for (sigma, c) in [(1e-6, 10.0), (1e6, 10.0), (1.0, 1e-12), (1.0, 1e12)] {
            match train(&x, &y, sigma, c) {
                Ok(m) => exports_finite_or_refuses(&m, &format!("σ {sigma} c {c}")),
                Err(e) => assert!(e.to_string().contains("positive definite"), "{e}"),
            }
        }
        for (sigma, c) in [
            (0.0, 1.0),
            (f64::INFINITY, 1.0),
            (1.0, 0.0),
            (1.0, f64::NAN),
        ] {
            let e = train(&x, &y, sigma, c).unwrap_err().to_string();
            assert!(e.contains("must be a positive finite number"), "{e}");
        }
    }

    #[test]
    fn degenerate_data() {
        // Duplicated inputs: fine with a finite c.
        let (mut x, mut y) = data(30);
        x.extend(x.clone());
        y.extend(y.clone());
        exports_finite_or_refuses(&train(&x, &y, 1.0, 100.0).unwrap(), "duplicates");
        // One temperature point, or dT/dt ≡ 0: the constant feature is named.
        let (x, y) = data(30);
        let one_t: Vec<Vec<f64>> = x.iter().map(|r| vec![25.0, r[1]]).collect();
        let e = train(&one_t, &y, 1.0, 10.0).unwrap_err().to_string();
        assert!(e.contains("temp_c") && e.contains("constant"), "{e}");
        let still: Vec<Vec<f64>> = x.iter().map(|r| vec![r[0], 0.0]).collect();
        let e = train(&still, &y, 1.0, 10.0).unwrap_err().to_string();
        assert!(
            e.contains("temp_rate_c_per_s") && e.contains("constant"),
            "{e}"
        );
        // NaN in the data: named, never trained on.
        let mut bad = y.clone();
        bad[7] = f64::NAN;
        let e = train(&x, &bad, 1.0, 10.0).unwrap_err().to_string();
        assert!(e.contains("non-finite") || e.contains("NaN"), "{e}");
    }
}
