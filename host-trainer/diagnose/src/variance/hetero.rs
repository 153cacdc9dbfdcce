//! The noise-scale test (`heteroscedastic`: white-noise σ multiplier 1 + k·((T − ref)/30)²).
//!
//! The term leaves the mean alone, so the 100 s means cannot see it; the 1 Hz samples can.
//! Each 100 s block gives the variance of its samples about their own straight line (the
//! line takes out the bias's change within the block, the 100–10 000 s Gauss–Markov noise
//! barely moves inside 100 s), so z_b = ln v_b = c + 2·ln(1 + k·x_b) + ε_b with ε_b
//! independent, of the same distribution (ln χ²_ν/ν, ν = samples − 2). The test regresses
//! z on the block temperature and its square (the term linearised: ln(1 + k·x) ≈ k·x is
//! quadratic in T whatever the reference), scored by the same ΔBIC as the mean families;
//! being a ratio of sums of squares it needs neither σ nor ν, and its null distribution is
//! drawn in the same bootstrap replicates, so the look-elsewhere over all families holds.
//! The parameters (k, ref) are then fitted by non-linear least squares on z.

use rand::{Rng, RngExt};

use super::counts::MIN_COUNT_SIGMA;
use super::counts::{block_mean_counts, summed_samples, undithered_count, CountVariance};
use super::detrend::{detrend_degree, line_residuals, line_variance, Detrend};
use super::tails::{heavy_tailed, log_root_scale};
use crate::linalg::{centred, dot, Basis};
use crate::prepare::{read_quantum, Prepared};
use crate::score::{delta_bic, CHUNK_BLOCKS, FOLDS};
use rlg_physics::Term;

/// The block log-variances of a recording and the test's design.
pub struct VarianceTest {
    /// ln of each block's sample variance about its own line.
    pub z: Vec<f64>,
    /// Block mean temperatures, °C.
    pub(super) temp: Vec<f64>,
    /// [T, T²] (scaled) made orthogonal to the constant, orthonormalised.
    pub(super) perp: Basis,
    /// ΔBIC of the quadratic log-variance regression over the constant.
    pub dbic: f64,
    /// An undithered count's part of the variance, when the rate is one (`z` is then the
    /// log-variance less it).
    pub(super) quant: Option<CountVariance>,
    /// Whether the block log-scales are ½-power means (heavy-tailed noise, see
    /// [`heavy_tailed`]) instead of log-variances.
    pub(super) heavy: bool,
    /// Degree of the polynomial each block is taken about ([`detrend_degree`]).
    pub(super) degree: usize,
}

/// ln(1 + k·((T − ref)/30)²)·2 per block: the log-variance the term adds (NaN where the
/// multiplier is not positive).
pub fn log_scale(temp: &[f64], k: f64, ref_c: f64) -> Vec<f64> {
    temp.iter()
        .map(|t| {
            let x = ((t - ref_c) / 30.0).powi(2);
            let s = 1.0 + k * x;
            if s > 0.0 {
                2.0 * s.ln()
            } else {
                f64::NAN
            }
        })
        .collect()
}

impl VarianceTest {
    /// The test on a prepared recording; None when a block has no variance (a constant or
    /// too coarsely quantised rate; on a count summed, a block whose sums are all equal),
    /// where a log-variance is undefined, or when the rate is an undithered count whose
    /// noise, summed where it helps, is under [`MIN_COUNT_SIGMA`] counts. A coarse count with
    /// little noise can leave a few blocks whose sums are all equal, even summed, and the
    /// test then does not run.
    pub fn new(prep: &Prepared) -> Option<Self> {
        Self::from_samples(&prep.rate_dph, prep.block, prep.temp_b.clone())
    }

    /// The test on samples `rate` in blocks of `m`, at block temperatures `temp`; on an
    /// undithered count, on sums of [`summed_samples`] samples.
    pub(super) fn from_samples(rate: &[f64], m: usize, temp: Vec<f64>) -> Option<Self> {
        match undithered_count(rate) {
            Some((q, sigma)) => {
                let k = summed_samples(sigma / q, m);
                if k == 1 {
                    return Self::of_samples(rate, m, temp, Some(q));
                }
                // Each block's variance of disjoint k-sums about their line, averaged over
                // the k ways of cutting the block into sums; the mean count of a sum from
                // the whole block's count.
                let z: Vec<f64> = rate
                    .chunks_exact(m)
                    .map(|b| {
                        let v = (0..k)
                            .filter_map(|o| {
                                let sums: Vec<f64> =
                                    b[o..].chunks_exact(k).map(|c| c.iter().sum()).collect();
                                line_variance(&sums)
                            })
                            .sum::<f64>()
                            / k as f64;
                        (v > 0.0).then(|| v.ln())
                    })
                    .collect::<Option<_>>()?;
                let xi = block_mean_counts(rate, m, q, k);
                Self::of_counts(z, xi, (m / k, k), temp, 1, false)
            }
            None => Self::of_samples(rate, m, temp, None),
        }
    }

    /// The test on samples `rate` in blocks of `m`, whose quantum is `counted` when they are
    /// an undithered count.
    fn of_samples(rate: &[f64], m: usize, temp: Vec<f64>, counted: Option<f64>) -> Option<Self> {
        // Only on a continuous output: on counts, even ones the noise dithers (σ half a
        // count), the mean of |e|^½ follows where the block's mean rate falls between counts
        // far more than the variance does (on a heavy-tailed record of counts with no noise
        // scale it finds a strong one).
        let degree = detrend_degree(rate, m);
        let det = (degree > 1).then(|| Detrend::new(m, degree));
        let residuals = |c: &[f64]| {
            det.as_ref()
                .map_or_else(|| line_residuals(c), |d| d.residuals(c))
        };
        let variance = |c: &[f64]| {
            det.as_ref()
                .map_or_else(|| line_variance(c), |d| d.variance(c))
        };
        let heavy = read_quantum(rate).is_none() && heavy_tailed(rate, m, residuals);
        let z: Vec<f64> = if heavy {
            rate.chunks_exact(m)
                .map(|c| log_root_scale(&residuals(c)))
                .collect::<Option<_>>()?
        } else {
            rate.chunks_exact(m)
                .map(|c| variance(c).filter(|v| *v > 0.0).map(f64::ln))
                .collect::<Option<_>>()?
        };
        match counted {
            None => Some(Self::of_log_scales(z, temp, None, heavy, degree)),
            Some(q) => {
                let xi = block_mean_counts(rate, m, q, 1);
                Self::of_counts(z, xi, (m, 1), temp, degree, heavy)
            }
        }
    }

    /// The test on the block log-variances `z` of an undithered count whose blocks' mean
    /// counts per sample are `xi`, `n` values a block each the sum of `summed` samples: the
    /// count's own variance taken out ([`CountVariance`]);
    /// None when the noise is under [`MIN_COUNT_SIGMA`] counts.
    fn of_counts(
        mut z: Vec<f64>,
        xi: Vec<f64>,
        (n, summed): (usize, usize),
        temp: Vec<f64>,
        degree: usize,
        heavy: bool,
    ) -> Option<Self> {
        let c = CountVariance::fit(xi, &z, n, summed);
        if c.s < MIN_COUNT_SIGMA {
            return None;
        }
        for (v, g) in z.iter_mut().zip(&c.base) {
            *v -= g;
        }
        Some(Self::of_log_scales(z, temp, Some(c), heavy, degree))
    }

    /// The test on block log-scales `z` at block temperatures `temp`.
    fn of_log_scales(
        z: Vec<f64>,
        temp: Vec<f64>,
        quant: Option<CountVariance>,
        heavy: bool,
        degree: usize,
    ) -> Self {
        let mid = temp.iter().sum::<f64>() / temp.len().max(1) as f64;
        let u: Vec<f64> = temp.iter().map(|t| (t - mid) / 30.0).collect();
        let u2: Vec<f64> = u.iter().map(|v| v * v).collect();
        let perp = Basis::new(&[centred(&u), centred(&u2)]);
        let mut t = Self {
            z,
            temp,
            perp,
            dbic: 0.0,
            quant,
            heavy,
            degree,
        };
        t.dbic = t.statistic(&t.z);
        t
    }

    /// The log-variance the term adds to each block (NaN where the multiplier is not
    /// positive): 2·ln(1 + k·x) on a continuous output; on an undithered count the change of
    /// ln(count variance) when the noise σ is scaled by 1 + k·x, which the fraction's part
    /// dilutes.
    pub(super) fn log_scale(&self, k: f64, ref_c: f64) -> Vec<f64> {
        match &self.quant {
            None => log_scale(&self.temp, k, ref_c),
            Some(c) => c
                .log_var(c.s_ref(), |b| {
                    1.0 + k * ((self.temp[b] - ref_c) / 30.0).powi(2)
                })
                .into_iter()
                .zip(&c.base)
                .map(|(a, b)| a - b)
                .collect(),
        }
    }

    /// Whether the rate is an undithered count (its variance modelled, see `CountVariance`).
    pub fn counts(&self) -> bool {
        self.quant.is_some()
    }

    /// How many samples each of the test's values sums (1 but on an undithered count whose
    /// noise is under a fraction of a count, [`summed_samples`]).
    pub fn summed(&self) -> usize {
        self.quant.as_ref().map_or(1, |c| c.summed)
    }

    /// Degree of the polynomial each block's variance is taken about (1: its line).
    pub fn detrend_degree(&self) -> usize {
        self.degree
    }

    /// Whether the block scales are ½-power means (heavy-tailed white noise).
    pub fn heavy_tailed(&self) -> bool {
        self.heavy
    }

    /// ΔBIC of the quadratic regression of `z` over the constant.
    pub(super) fn statistic(&self, z: &[f64]) -> f64 {
        let zc = centred(z);
        let rss0 = dot(&zc, &zc);
        let r = self.perp.residual(&zc);
        let rss1 = dot(&r, &r);
        delta_bic(z.len(), rss0, rss0 - rss1, self.perp.q.len())
    }

    /// Whether the block log-scales follow time rather than temperature, on blocks at times
    /// `time_s`. The level in time is the best of three shapes: a quadratic (a drift), a
    /// step at one time (a change part way), an episode between two times (a disturbance
    /// that ends); the times of a step or an episode are charged as parameters. On a record
    /// of `several_cycles` (two or more temperature cycles), the noise follows time when that
    /// level explains the log-scales at least as well as the quadratic in temperature and the
    /// temperature's quadratic adds nothing beside it (its ΔBIC over the level in time is not
    /// negative). On one cycle, where time and temperature move together, the level in time
    /// must also add beside the temperature's quadratic (ΔBIC < 0): a noise level that
    /// follows temperature is fitted by its quadratic as well as by any shape in time, and
    /// keeps its name. On an undithered count each level is fitted through the count's model
    /// ([`CountVariance::fit_level`]). Returns the temperature's ΔBIC beside the level in
    /// time, and the level, where the noise follows time.
    pub fn in_time_not_temperature(
        &self,
        time_s: &[f64],
        several_cycles: bool,
    ) -> Option<(f64, LevelInTime)> {
        self.level_in_time(time_s, several_cycles)
            .map(|l| (l.dbic_temp_beside, l.level))
    }

    /// Each block's white-noise variance relative to the record's (mean 1) where the 1 Hz
    /// noise level follows time and not temperature ([`Self::in_time_not_temperature`]) and
    /// that level in time is strong evidence (its ΔBIC over a constant level under
    /// [`WHITE_LEVEL_DBIC`]): the level's least-squares fit to the block log-scales, taken
    /// back to variances. The bootstraps of the block means' tests draw their white noise
    /// at it: a white level that doubles for a few hours makes those hours' means scatter
    /// twice as wide, and replicates of a stationary noise model do not.
    /// On an undithered count the log-scales are those less the count's own part, and the
    /// level is their fit alone (the count's model is not refitted beside it), an
    /// approximation where the count's part is large. `None` otherwise.
    pub fn white_level_in_time(
        &self,
        time_s: &[f64],
        several_cycles: bool,
    ) -> Option<(LevelInTime, Vec<f64>)> {
        let l = self.level_in_time(time_s, several_cycles)?;
        if l.dbic_time >= WHITE_LEVEL_DBIC {
            return None;
        }
        let zc = centred(&self.z);
        let r = Basis::new(&l.level.columns(time_s)).residual(&zc);
        let w: Vec<f64> = zc.iter().zip(&r).map(|(z, e)| (z - e).exp()).collect();
        let mean = w.iter().sum::<f64>() / w.len() as f64;
        (mean > 0.0 && mean.is_finite()).then(|| (l.level, w.iter().map(|v| v / mean).collect()))
    }

    /// The best level in time and how it compares with the quadratic in temperature (see
    /// [`Self::in_time_not_temperature`]), where the noise follows time.
    fn level_in_time(&self, time_s: &[f64], several_cycles: bool) -> Option<TimeLevel> {
        let n = self.z.len();
        if time_s.len() != n || n < 8 {
            return None;
        }
        let zc = centred(&self.z);
        let rss0 = dot(&zc, &zc);
        let level = LevelInTime::best(&zc, time_s)?;
        let cols = level.columns(time_s);
        let mut both_cols = cols.clone();
        both_cols.extend(self.perp.q.iter().cloned());
        let (rss_t, rss_temp, rss_b) = match &self.quant {
            None => {
                let rss = |c: &[Vec<f64>]| {
                    let r = Basis::new(c).residual(&zc);
                    dot(&r, &r)
                };
                (rss(&cols), rss(&self.perp.q), rss(&both_cols))
            }
            // On an undithered count the noise level (in time, in temperature, both) is
            // fitted through the count's model, whose own part changes with it
            // (`CountVariance::fit_level`); the joint level starts from each single one, so
            // that it fits at least as well as either.
            Some(c) => {
                let z_raw: Vec<f64> = self.z.iter().zip(&c.base).map(|(a, b)| a + b).collect();
                let (rss_t, th_t) = c.fit_level(&z_raw, &cols, None);
                let (rss_temp, th_temp) = c.fit_level(&z_raw, &self.perp.q, None);
                let k = self.perp.q.len();
                let from_time = [&th_t[..], &vec![0.0; k][..]].concat();
                let from_temp = [&th_temp[..1], &vec![0.0; cols.len()][..], &th_temp[1..]].concat();
                let rss_b = c
                    .fit_level(&z_raw, &both_cols, Some(from_time))
                    .0
                    .min(c.fit_level(&z_raw, &both_cols, Some(from_temp)).0);
                (rss_t, rss_temp, rss_b)
            }
        };
        let k_time = level.parameters();
        let dbic_time = delta_bic(n, rss0, rss0 - rss_t, k_time);
        let dbic_temp_beside = delta_bic(n, rss_t, rss_t - rss_b, self.perp.q.len());
        let dbic_time_beside = delta_bic(n, rss_temp, rss_temp - rss_b, k_time);
        let dbic_temp = delta_bic(n, rss0, rss0 - rss_temp, self.perp.q.len());
        let in_time = dbic_temp_beside >= 0.0
            && if several_cycles {
                dbic_time <= dbic_temp
            } else {
                dbic_time_beside < 0.0
            };
        in_time.then_some(TimeLevel {
            level,
            dbic_time,
            dbic_temp_beside,
        })
    }

    /// One bootstrap replicate of the statistic under constant noise: the recording's own
    /// block log-variances in a random order (a permutation test). A drawn ln(χ²_ν/ν) per
    /// block assumes Gaussian 1 Hz samples; permuted, the blocks keep whatever distribution
    /// their variances have (heavy-tailed noise, spikes, a quantised output) and lose only
    /// their order in temperature, which is what is tested.
    pub fn replicate<R: Rng>(&self, rng: &mut R) -> f64 {
        let mut z = self.z.clone();
        for i in (1..z.len()).rev() {
            z.swap(i, rng.random_range(0..=i));
        }
        self.statistic(&z)
    }

    /// Held-out sums of squares of z (without the term, with it): the term's shape fixed,
    /// its amplitude and the constant fitted on the training folds (1 h chunks interleaved
    /// over four folds, as the mean families' cross-validation).
    pub fn heldout(&self, term: &Term) -> (f64, f64) {
        let Term::Heteroscedastic { k, ref_c } = term else {
            return (0.0, 0.0);
        };
        let g = self.log_scale(*k, *ref_c);
        let nb = self.z.len();
        let fold = |b: usize| (b / CHUNK_BLOCKS) % FOLDS;
        let (mut rss0, mut rss1) = (0.0, 0.0);
        for f in 0..FOLDS {
            let train: Vec<usize> = (0..nb).filter(|&b| fold(b) != f).collect();
            if train.len() == nb || train.is_empty() {
                continue;
            }
            let m = train.len() as f64;
            let zbar = train.iter().map(|&b| self.z[b]).sum::<f64>() / m;
            let gbar = train.iter().map(|&b| g[b]).sum::<f64>() / m;
            let (mut sgz, mut sgg) = (0.0, 0.0);
            for &b in &train {
                sgz += (g[b] - gbar) * (self.z[b] - zbar);
                sgg += (g[b] - gbar).powi(2);
            }
            let a = if sgg > 0.0 { sgz / sgg } else { 0.0 };
            for b in (0..nb).filter(|&b| fold(b) == f) {
                rss0 += (self.z[b] - zbar).powi(2);
                let p = zbar + a * (g[b] - gbar);
                rss1 += (self.z[b] - p).powi(2);
            }
        }
        (rss0, rss1)
    }

    /// The fitted log-variance change per block, about its mean (for locating the effect).
    pub fn effect(&self, term: &Term) -> Vec<f64> {
        match term {
            Term::Heteroscedastic { k, ref_c } => centred(&self.log_scale(*k, *ref_c)),
            _ => vec![0.0; self.z.len()],
        }
    }
}

/// Held-out sums of squares (without, with) of the block log-variances of `prep` for a
/// `heteroscedastic` term (see [`VarianceTest::heldout`]); None when the test cannot run.
pub fn heldout_variance(prep: &Prepared, term: &Term) -> Option<(f64, f64)> {
    Some(VarianceTest::new(prep)?.heldout(term))
}

/// Detectability of a `heteroscedastic` term on samples at temperatures `temp_c` (1 Hz): the
/// signal-to-noise ratio of the best test for that exact shape with the noise known,
/// D² = ½·Σ (g_i − ḡ)², g_i = 2·ln(1 + k·x_i) the log-variance it adds (the Fisher
/// information of a Gaussian sample's log-variance is ½), the constant part being absorbed
/// by the fitted noise level. Assumes the white noise carries the 1 s variance, as the
/// simulator's Gauss–Markov bank (correlation times ≥ 100 s) leaves it.
pub fn heteroscedastic_detectability(temp_c: &[f64], k: f64, ref_c: f64) -> f64 {
    let g = centred(&log_scale(temp_c, k, ref_c));
    (0.5 * dot(&g, &g)).sqrt()
}

/// A level in time's ΔBIC over a constant white level under which the tests of the block
/// means take it as known ([`VarianceTest::white_level_in_time`]): strong evidence on the
/// BIC's own scale, so that a clean record's chance best step or episode of the noise level
/// leaves the noise model stationary.
pub const WHITE_LEVEL_DBIC: f64 = -10.0;

/// The best level in time of the block log-scales, where the noise follows it.
struct TimeLevel {
    level: LevelInTime,
    /// Its ΔBIC over a constant level.
    dbic_time: f64,
    /// The temperature's quadratic's ΔBIC beside it.
    dbic_temp_beside: f64,
}

/// A white-noise level in time, the alternative to a level in temperature
/// ([`VarianceTest::in_time_not_temperature`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LevelInTime {
    /// A quadratic in time.
    Drift,
    /// A change of level at block `at`.
    Step {
        /// The first block at the new level.
        at: usize,
    },
    /// Another level over blocks `from..to`.
    Episode {
        /// The first block at the other level.
        from: usize,
        /// The first block back at the level of the rest.
        to: usize,
    },
}

/// At most this many times a step or an episode's ends are tried at.
const LEVEL_TIMES: usize = 120;

impl LevelInTime {
    /// What the level does, for a note: on blocks at times `time_s`, "drifts over the
    /// record", "changes at 4.2 h", "is another from 3.1 h to 7.5 h".
    pub fn describe(self, time_s: &[f64]) -> String {
        let h = |b: usize| time_s.get(b).map_or(f64::NAN, |t| (t - time_s[0]) / 3600.0);
        match self {
            LevelInTime::Drift => "drifts over the record".to_string(),
            LevelInTime::Step { at } => format!("changes at {:.1} h", h(at)),
            LevelInTime::Episode { from, to } => {
                format!("is another from {:.1} h to {:.1} h", h(from), h(to))
            }
        }
    }

    /// Parameters charged: the drift's two coefficients, a step's level and time, an
    /// episode's level and two times.
    fn parameters(self) -> usize {
        match self {
            LevelInTime::Drift | LevelInTime::Step { .. } => 2,
            LevelInTime::Episode { .. } => 3,
        }
    }

    /// Its centred columns on the blocks at `time_s`.
    fn columns(self, time_s: &[f64]) -> Vec<Vec<f64>> {
        let n = time_s.len();
        let indicator = |a: usize, b: usize| -> Vec<Vec<f64>> {
            let x: Vec<f64> = (0..n)
                .map(|i| f64::from(u8::from((a..b).contains(&i))))
                .collect();
            vec![centred(&x)]
        };
        match self {
            LevelInTime::Drift => {
                let (t0, t1) = (time_s[0], time_s[n - 1]);
                let span = (t1 - t0).max(f64::MIN_POSITIVE);
                let s: Vec<f64> = time_s.iter().map(|t| (t - t0) / span - 0.5).collect();
                let s2: Vec<f64> = s.iter().map(|v| v * v).collect();
                vec![centred(&s), centred(&s2)]
            }
            LevelInTime::Step { at } => indicator(at, n),
            LevelInTime::Episode { from, to } => indicator(from, to),
        }
    }

    /// The shape of least ΔBIC over the centred log-scales `zc` at `time_s`. A step or an
    /// episode is scored in closed form from prefix sums: a centred indicator of m of n
    /// blocks has squared norm m(n − m)/n and takes (Σ of zc over its blocks)² of the sum
    /// of squares; each lies at least 5 % of the blocks from either end and holds 5 % of them.
    pub(crate) fn best(zc: &[f64], time_s: &[f64]) -> Option<LevelInTime> {
        let n = zc.len();
        let rss0 = dot(zc, zc);
        if rss0 <= 0.0 {
            return None;
        }
        let mut prefix = Vec::with_capacity(n + 1);
        prefix.push(0.0);
        for v in zc {
            prefix.push(prefix.last().copied().unwrap_or(0.0) + v);
        }
        let edge = (n / 20).max(2);
        if n < 2 * edge + 2 {
            return None;
        }
        let stride = ((n - 2 * edge) / LEVEL_TIMES).max(1);
        let times: Vec<usize> = (edge..=n - edge).step_by(stride).collect();
        let score = |a: usize, b: usize, k: usize| {
            let m = (b - a) as f64;
            let g = m * (n as f64 - m) / n as f64;
            let s = prefix[b] - prefix[a];
            delta_bic(n, rss0, s * s / g, k)
        };
        let drift_cols = LevelInTime::Drift.columns(time_s);
        let r = Basis::new(&drift_cols).residual(zc);
        let mut best = (
            delta_bic(n, rss0, rss0 - dot(&r, &r), 2),
            LevelInTime::Drift,
        );
        for &at in &times {
            let d = score(at, n, 2);
            if d < best.0 {
                best = (d, LevelInTime::Step { at });
            }
        }
        for (i, &from) in times.iter().enumerate() {
            for &to in &times[i + 1..] {
                if to - from < edge {
                    continue;
                }
                let d = score(from, to, 3);
                if d < best.0 {
                    best = (d, LevelInTime::Episode { from, to });
                }
            }
        }
        Some(best.1)
    }
}
