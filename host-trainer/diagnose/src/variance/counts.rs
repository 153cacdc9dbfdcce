//! An undithered count's own variance: where the gyro's output is whole angle counts per
//! sample and the noise does not dither them, each block's variance follows where its mean
//! rate falls between counts, that is the bias, that is temperature. The noise-scale test
//! takes that part out ([`CountVariance`]), and where the noise is a small fraction of a
//! count it runs on sums of samples ([`summed_samples`]).

use std::sync::atomic::{AtomicU64, Ordering};

use crate::linalg::{centred, dot, Basis};
use crate::minimise::grid_then_golden;
use crate::prepare::read_quantum;

/// The variance of an undithered angle count, in counts² per sample, at each block: the rate
/// x counts per sample plus white noise n of σ = s counts, counted from an angle whose
/// fractional part is uniform, gives samples ⌊u + x + n⌋ of variance
/// s² + E[frac(x + n)·(1 − frac(x + n))] (given x + n, the count over u is Bernoulli in its
/// fraction). The second term follows where the block's mean rate falls between counts, i.e.
/// the bias, i.e. temperature: removed from each block's log-variance with s fitted to the
/// record, it leaves the noise's own scale to the test.
pub(super) struct CountVariance {
    /// Each block's mean rate, counts per sample (a mean of whole counts).
    xi: Vec<f64>,
    /// The white noise σ in counts fitted to the blocks' log-variances under constant noise.
    pub(super) s: f64,
    /// ln of each block's count variance at `s`.
    pub(super) base: Vec<f64>,
    /// σ in counts at the term's reference temperature, as the term's fit last set it (f64
    /// bits; the test is shared by the bootstrap's threads, which never read it).
    pub(super) s_ref: AtomicU64,
    /// What the blocks' lines make of the count's own part ([`count_line_factor`]).
    line: f64,
    /// Samples summed into each of the test's values ([`summed_samples`]; 1: none).
    pub(super) summed: usize,
}

/// The expected variance about its least-squares line of `n` values whose errors are
/// differences of independent uniform phases (e_j − e_{j+1}: lag-one correlation −½), over
/// their variance: tr((I − H)R)/(n − 2) with R = tridiag(−½, 1, −½), u₀ᵀRu₀ = 1/n and
/// u₁ᵀRu₁ = 3/n for the orthonormal constant and slope, so (n − 4/n)/(n − 2). White noise's
/// is 1; the count's part of a block of 100 samples reads 2 % high, of a dozen sums 18 %,
/// which, taken for noise, biases a fitted noise scale low (tests
/// `noise_scale_on_summed_counts_is_found`, `noise_scale_on_counts_is_found`).
fn count_line_factor(n: usize) -> f64 {
    let n = n.max(3) as f64;
    (n - 4.0 / n) / (n - 2.0)
}

/// frac(y)·(1 − frac(y)) = 1/6 − Σₘ cos(2πmy)/(π²m²); over y = x + n, n ~ N(0, s²), each
/// harmonic is damped by exp(−2π²m²s²). Written out because no crate has it; the damping is
/// carried as a running product (one exp per call).
pub(super) fn count_variance(x: f64, s: f64) -> f64 {
    use std::f64::consts::PI;
    let q = (-2.0 * PI * PI * s * s).exp();
    let (mut damp, mut step) = (q, q * q * q);
    let mut h = 1.0 / 6.0;
    for m in 1..=400 {
        let mf = f64::from(m);
        h -= (2.0 * PI * mf * x).cos() * damp / (PI * PI * mf * mf);
        // q^(m²) → q^((m+1)²) = q^(m²)·q^(2m+1).
        damp *= step;
        step *= q * q;
        if damp < 1e-10 {
            break;
        }
    }
    s * s + h.max(0.0)
}

/// The smallest noise, in counts, of the values (samples, or sums of them where the noise is
/// a small fraction of a count: [`summed_samples`]) on which the test runs on an undithered
/// count. Below it the noise's own share of the values' variance is under a fifth (s²
/// against the fraction's ≈ 1/6), so a noise scale moves the log-variance by under a fifth
/// of what it does on a continuous output, and what moves it most is the count model's
/// detail: the rate's own drift within a block, a spike. Run on counts many times their
/// noise, the test calls a noise scale where there is none.
pub const MIN_COUNT_SIGMA: f64 = 0.2;

impl CountVariance {
    /// The smallest σ fitted, in counts: below it the series needs hundreds of harmonics and
    /// the count's variance is the fraction's alone.
    const S_MIN: f64 = 0.01;

    /// ln of each block's count variance at the noise σ `s` times `scale[b]`.
    pub(super) fn log_var(&self, s: f64, scale: impl Fn(usize) -> f64) -> Vec<f64> {
        self.xi
            .iter()
            .enumerate()
            .map(|(b, x)| {
                let sb = s * scale(b);
                if sb > 0.0 {
                    let sv = sb.max(Self::S_MIN);
                    (sv * sv + self.line * (count_variance(*x, sv) - sv * sv)).ln()
                } else {
                    f64::NAN
                }
            })
            .collect()
    }

    /// s fitted by least squares of z − ln(count variance) about its mean (log grid of 61
    /// points over 0.01…3 counts, then golden section).
    pub(super) fn fit(xi: Vec<f64>, z: &[f64], n: usize, summed: usize) -> Self {
        let mut c = Self {
            line: count_line_factor(n),
            summed,
            xi,
            s: 1.0,
            base: Vec::new(),
            s_ref: AtomicU64::new(1f64.to_bits()),
        };
        let grid: Vec<f64> = (0..61)
            .map(|i| Self::S_MIN * 300f64.powf(f64::from(i) / 60.0))
            .collect();
        let rss = |s: f64| {
            let g = c.log_var(s, |_| 1.0);
            let d: Vec<f64> = z.iter().zip(&g).map(|(a, b)| a - b).collect();
            let dc = centred(&d);
            dot(&dc, &dc)
        };
        c.s = grid_then_golden(&grid, 40, rss).0;
        c.base = c.log_var(c.s, |_| 1.0);
        c.s_ref.store(c.s.to_bits(), Ordering::Relaxed);
        c
    }

    /// The least residual sum of squares of the blocks' raw log-variances `z_raw` about
    /// their mean under a noise level σ_b = s·exp(Σⱼ βⱼ·`cols`ⱼ[b]) through the count's
    /// model, and its (ln s, β): fitted by least squares from `start` (the record's constant
    /// s and β = 0 where `None`). Where the noise level changes (in time, say) the count's
    /// own part changes with it, by how much depending on where each block's rate falls
    /// between counts, that is on the bias and temperature: a level taken off the
    /// log-variances less the count's part at one σ leaves that dependence in, and a
    /// temperature quadratic then seems to add beside a level in time.
    ///
    /// Gauss–Newton with step halving, by hand: one to five parameters of a smooth model,
    /// started at a fit already made, so that no step is far; the derivatives are central
    /// differences of the model.
    pub(super) fn fit_level(
        &self,
        z_raw: &[f64],
        cols: &[Vec<f64>],
        start: Option<Vec<f64>>,
    ) -> (f64, Vec<f64>) {
        const H: f64 = 1e-4;
        let model = |theta: &[f64]| -> Vec<f64> {
            self.log_var(theta[0].exp(), |b| {
                cols.iter()
                    .zip(&theta[1..])
                    .map(|(c, beta)| beta * c[b])
                    .sum::<f64>()
                    .exp()
            })
        };
        let residual = |theta: &[f64]| -> Vec<f64> {
            let g = model(theta);
            centred(&z_raw.iter().zip(&g).map(|(a, b)| a - b).collect::<Vec<_>>())
        };
        let jacobian = |theta: &[f64]| -> Vec<Vec<f64>> {
            (0..theta.len())
                .map(|j| {
                    let (mut up, mut down) = (theta.to_vec(), theta.to_vec());
                    up[j] += H;
                    down[j] -= H;
                    let (gu, gd) = (model(&up), model(&down));
                    centred(
                        &gu.iter()
                            .zip(&gd)
                            .map(|(a, b)| (a - b) / (2.0 * H))
                            .collect::<Vec<_>>(),
                    )
                })
                .collect()
        };
        let mut theta = start.unwrap_or_else(|| {
            let mut t = vec![0.0; cols.len() + 1];
            t[0] = self.s.max(Self::S_MIN).ln();
            t
        });
        let mut r = residual(&theta);
        let mut rss = dot(&r, &r);
        for _ in 0..30 {
            let step = Basis::new(&jacobian(&theta)).coefficients(&r);
            let mut lambda = 1.0;
            let improved = loop {
                let trial: Vec<f64> = theta
                    .iter()
                    .zip(&step)
                    .map(|(t, d)| t + lambda * d)
                    .collect();
                let rt = residual(&trial);
                let rss_t = dot(&rt, &rt);
                if rss_t.is_finite() && rss_t < rss {
                    break Some((trial, rt, rss_t));
                }
                lambda *= 0.5;
                if lambda < 1e-3 {
                    break None;
                }
            };
            let Some((trial, rt, rss_t)) = improved else {
                break;
            };
            let done = rss - rss_t < 1e-10 * rss.max(f64::MIN_POSITIVE);
            (theta, r, rss) = (trial, rt, rss_t);
            if done {
                break;
            }
        }
        (rss, theta)
    }

    pub(super) fn s_ref(&self) -> f64 {
        f64::from_bits(self.s_ref.load(Ordering::Relaxed))
    }
}

/// The count of a gyro whose output `rate_dph` is angle increments (the rate a whole number
/// of counts per sample), °/h, when the noise does not dither it; `None` for a continuous
/// output or a well-dithered count. Undithered, the variance of the samples depends on where
/// the true rate falls between counts, which moves with the bias and so with temperature: a
/// noise scale in T that no gyro noise causes (left in, it makes the test find one on clean
/// recordings with 0.1″ counts), which the test then takes out (`CountVariance`). The
/// modulation falls as exp(−2π²σ²/q²) with σ the per-sample noise: below 1 % for σ ≥ q/2. σ is read from sums
/// of 10 samples, whose quantisation error is bounded (a count at each end, variance q²/6)
/// while the noise's variance grows tenfold.
pub fn output_quantum(rate_dph: &[f64]) -> Option<f64> {
    undithered_count(rate_dph).map(|(q, _)| q)
}

/// The count's quantum and the per-sample noise σ (both °/h) of an undithered count (see
/// [`output_quantum`]).
pub(super) fn undithered_count(rate_dph: &[f64]) -> Option<(f64, f64)> {
    let q = read_quantum(rate_dph)?;
    let sums: Vec<f64> = rate_dph.chunks_exact(10).map(|c| c.iter().sum()).collect();
    let d: Vec<f64> = sums.windows(2).map(|w| w[1] - w[0]).collect();
    let var_sum = d.iter().map(|v| v * v).sum::<f64>() / (2.0 * d.len().max(1) as f64);
    let sigma = ((var_sum - q * q / 6.0).max(0.0) / 10.0).sqrt();
    (sigma < 0.5 * q).then_some((q, sigma))
}

/// Each block's mean count per `summed` samples of a count of quantum `q`, in blocks of
/// `m`: whole counts per sample, so that the mean is exact.
pub(super) fn block_mean_counts(rate: &[f64], m: usize, q: f64, summed: usize) -> Vec<f64> {
    rate.chunks_exact(m)
        .map(|c| summed as f64 * c.iter().map(|r| (r / q).round()).sum::<f64>() / m as f64)
        .collect()
}

/// The noise, in counts, that the samples of an undithered count are summed up to before
/// the noise-scale test (see [`summed_samples`]).
const SUMMED_COUNT_SIGMA: f64 = 0.4;

/// How many consecutive samples of an undithered count of per-sample noise `s` counts the
/// noise-scale test sums into one, in blocks of `m`: the fewest whose sum has noise
/// s·√k ≥ [`SUMMED_COUNT_SIGMA`], at most `m`/8.
///
/// A sum of k samples is the count over k samples: its variance is that of one sample with
/// the rate k·x and the noise s·√k (the counts at its two ends alone are quantised), so the
/// count's model is unchanged while the noise's share of the variance grows about k-fold.
/// Each block's variance is that of its disjoint sums about their line, averaged over the k
/// ways of cutting the block: of one dozen sums, a block where the rate sits near a whole
/// count has all equal (no log-variance) often enough to stop the test; moving sums, whose
/// line takes more of the noise's part than of the count's, bias k low. Under a fifth of a
/// count the samples' variance is nearly all where the rate falls between counts and the
/// test is not run (`MIN_COUNT_SIGMA`); summed, a count of 0.1 counts' noise (a 0.16″
/// quantum at the paper's noise) holds a noise scale the samples do not show: unsummed, the
/// test would not run on such records at all; summed, it finds most noise scales hidden in
/// them.
pub(super) fn summed_samples(s: f64, m: usize) -> usize {
    let k = if s > 0.0 {
        (SUMMED_COUNT_SIGMA / s).powi(2).ceil() as usize
    } else {
        usize::MAX
    };
    k.clamp(1, (m / 8).max(1))
}
