//! Equivalent degrees of freedom (EDF) of Allan-type variance estimates, power-law noise
//! identification per averaging time, and the χ² confidence interval built from them —
//! the way Stable32 and allantools report "min sigma / max sigma".
//!
//! Conventions follow NIST SP 1065: `alpha` is the exponent of the fractional-frequency
//! spectrum S_y(f) ∝ f^alpha, so 2 = white PM, 1 = flicker PM, 0 = white FM, −1 = flicker
//! FM, −2 = random-walk FM. For a gyro the rate is the "frequency" and the integrated angle
//! the "phase": white rate noise (angle random walk) is alpha 0, bias-instability flicker is
//! alpha −1, rate random walk is alpha −2 and white angle noise (readout quantisation) is
//! alpha 2.
//!
//! The EDF is Greenhall's algorithm (C. A. Greenhall and W. J. Riley, "Uncertainty of
//! stability variances based on finite differences", PTTI 2003), case by case as allantools'
//! `edf_greenhall` has it. Its model takes each phase sample as the average of the
//! continuous phase over τ0. For point-sampled angle with independent rate samples the true
//! EDF of the m = 1 estimate of white FM is 2M/3 rather than the model's 18M/23, so the first
//! interval is about 8 % too narrow there (coverage ≈ 64 % instead of 68.3 %); from m = 2 on
//! the model errs slightly on the wide side (≈ 70 % in simulation).

use statrs::distribution::{ChiSquared, Continuous, ContinuousCDF, Normal};

/// Two-sided 1σ confidence, erf(1/√2) = 0.682 689 …; Stable32 prints it as "0.683".
pub const CONFIDENCE_1SIGMA: f64 = 0.682_689_492_137_085_9;

/// Fewest values (decimated phase or τ-averaged frequency) the lag-1 autocorrelation
/// identification is used with; below it the B1 ratio decides (Riley & Greenhall).
pub const LAG1_MIN_POINTS: usize = 30;

/// Block length J_max of Greenhall's algorithm: sums longer than this switch to the
/// asymptotic tables.
const J_MAX: f64 = 100.0;

/// Equivalent degrees of freedom of the overlapping Allan (d = 2) or overlapping Hadamard
/// (d = 3) variance at averaging factor `m` from `n` phase points (n rate samples give n + 1
/// phase points), for power-law noise `alpha` (see the module doc).
///
/// NaN where the estimator is undefined: m = 0, d outside 1..=3, alpha outside −4..=2,
/// alpha + 2d ≤ 1 (e.g. alpha < −2 for the Allan variance), or fewer points than the
/// estimator's filter spans (d·m + 1; m + d·m for the modified variances).
pub fn edf_overlapping_adev(alpha: i32, d: u32, m: usize, n: usize) -> f64 {
    edf_greenhall(alpha, d, m, n, true, false)
}

/// Greenhall's EDF for the d-th difference variances: d = 1 first difference, 2 Allan,
/// 3 Hadamard; `overlapping` for the fully overlapped estimator (stride τ0), `modified` for
/// the modified variances (MVAR, TVAR). `n` is the number of phase points. NaN under the
/// conditions of [`edf_overlapping_adev`].
// Greenhall's algorithm written out by hand: no Rust crate provides it.
pub fn edf_greenhall(
    alpha: i32,
    d: u32,
    m: usize,
    n: usize,
    overlapping: bool,
    modified: bool,
) -> f64 {
    if m == 0 || !(1..=3).contains(&d) || !(-4..=2).contains(&alpha) || alpha + 2 * d as i32 <= 1 {
        return f64::NAN;
    }
    let (mf, nf, df) = (m as f64, n as f64, d as f64);
    let f = if modified { 1.0 } else { mf };
    let s = if overlapping { mf } else { 1.0 };
    // Length of the filter applied to the phase samples.
    let l = mf / f + mf * df;
    if nf < l {
        return f64::NAN;
    }
    let big_m = 1.0 + (s * (nf - l) / mf).floor();
    let j = big_m.min((df + 1.0) * s);
    let r = big_m / s;
    let inv_edf = if modified {
        // Case 1: modified variances, every alpha.
        if j <= J_MAX {
            basic_sum(j, big_m, s, 1.0, alpha, d) / (sz(0.0, 1.0, alpha, d).powi(2) * big_m)
        } else if r > df + 1.0 {
            let (a0, a1) = table1(alpha, d);
            (a0 - a1 / r) / r
        } else {
            let m_prime = J_MAX / r;
            basic_sum(J_MAX, J_MAX, m_prime, 1.0, alpha, d) / (sz(0.0, f, alpha, d).powi(2) * J_MAX)
        }
    } else if alpha <= 0 {
        // Case 2: unmodified variances, white FM and below.
        if j <= J_MAX {
            // Beyond J_MAX the τ0 averaging no longer matters: the m → ∞ kernel is used.
            let m_prime = if mf * (df + 1.0) <= J_MAX {
                mf
            } else {
                f64::INFINITY
            };
            basic_sum(j, big_m, s, m_prime, alpha, d) / (sz(0.0, m_prime, alpha, d).powi(2) * big_m)
        } else if r > df + 1.0 {
            let (a0, a1) = table2(alpha, d);
            (a0 - a1 / r) / r
        } else {
            let m_prime = J_MAX / r;
            basic_sum(J_MAX, J_MAX, m_prime, f64::INFINITY, alpha, d)
                / (sz(0.0, f64::INFINITY, alpha, d).powi(2) * J_MAX)
        }
    } else if alpha == 1 {
        // Case 3: unmodified variances, flicker PM (depends on m through ln m).
        if j <= J_MAX {
            basic_sum(j, big_m, s, mf, 1, d) / (sz(0.0, mf, 1, d).powi(2) * big_m)
        } else if r > df + 1.0 {
            let (a0, a1) = table2(alpha, d);
            let (b0, b1) = table3(d);
            (a0 - a1 / r) / ((b0 + b1 * mf.ln()).powi(2) * r)
        } else {
            let m_prime = J_MAX / r;
            let (b0, b1) = table3(d);
            basic_sum(J_MAX, J_MAX, m_prime, m_prime, 1, d) / ((b0 + b1 * mf.ln()).powi(2) * J_MAX)
        }
    } else {
        // Case 4: unmodified variances, white PM. Phase samples are independent, so the
        // d-th differences z_k and z_{k+i·m} correlate as C(2d, d−i)/C(2d, d); the sum runs
        // over the K − 1 such lags that fit (allantools leaves K ≤ d unimplemented; this is
        // the paper's closed form, of which its K > d branch is the limit).
        let k_cap = r.ceil();
        if k_cap <= df {
            let c0 = binomial(2 * d, d);
            let mut sum = 0.0;
            let mut i = 1u32;
            while f64::from(i) < k_cap {
                sum += (1.0 - f64::from(i) / r) * binomial(2 * d, d - i).powi(2);
                i += 1;
            }
            (1.0 + 2.0 * sum / (c0 * c0)) / big_m
        } else {
            let a0 = binomial(4 * d, 2 * d) / binomial(2 * d, d).powi(2);
            let a1 = df / 2.0;
            (a0 - a1 / r) / big_m
        }
    };
    1.0 / inv_edf
}

/// Binomial coefficient C(n, k) as f64 (n ≤ 12 here, exact).
fn binomial(n: u32, k: u32) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * f64::from(n - i) / f64::from(i + 1))
}

/// Eq. (10): the basic sum over the autocovariances of the differenced phase.
fn basic_sum(j: f64, big_m: f64, s: f64, f: f64, alpha: i32, d: u32) -> f64 {
    let first = sz(0.0, f, alpha, d).powi(2);
    let second = (1.0 - j / big_m) * sz(j / s, f, alpha, d).powi(2);
    // `j` is integral except in the J_MAX branches, where it is J_MAX itself.
    let third: f64 = (1..j as usize)
        .map(|jj| {
            let jf = jj as f64;
            2.0 * (1.0 - jf / big_m) * sz(jf / s, f, alpha, d).powi(2)
        })
        .sum();
    first + second + third
}

/// Eq. (9): autocovariance of the d-th difference, the 2d-th central difference of `sx`.
fn sz(t: f64, f: f64, alpha: i32, d: u32) -> f64 {
    let d_i = d as i32;
    (-d_i..=d_i)
        .map(|k| {
            let c = binomial(2 * d, (d_i + k) as u32);
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            sign * c * sx(t + f64::from(k), f, alpha)
        })
        .sum()
}

/// Eq. (8): autocovariance of the phase averaged over 1/F (F = ∞: not averaged).
fn sx(t: f64, f: f64, alpha: i32) -> f64 {
    if f.is_infinite() {
        return sw(t, alpha + 2);
    }
    f * f * (2.0 * sw(t, alpha) - sw(t - 1.0 / f, alpha) - sw(t + 1.0 / f, alpha))
}

/// Eq. (7): generalised autocovariance of the power-law process w with exponent `alpha`.
fn sw(t: f64, alpha: i32) -> f64 {
    let a = t.abs();
    let log_term = |p: i32| if t == 0.0 { 0.0 } else { t.powi(p) * a.ln() };
    match alpha {
        2 => -a,
        1 => log_term(2),
        0 => a.powi(3),
        -1 => log_term(4),
        -2 => a.powi(5),
        -3 => log_term(6),
        -4 => a.powi(7),
        _ => f64::NAN,
    }
}

/// Greenhall Table 1 (modified variances, large r): (a0, a1) for 1/edf = (a0 − a1/r)/r.
fn table1(alpha: i32, d: u32) -> (f64, f64) {
    const T: [[(f64, f64); 3]; 7] = [
        [
            (2.0 / 3.0, 1.0 / 3.0),
            (7.0 / 9.0, 1.0 / 2.0),
            (22.0 / 25.0, 2.0 / 3.0),
        ],
        [(0.840, 0.345), (0.997, 0.616), (1.141, 0.843)],
        [(1.079, 0.368), (1.033, 0.607), (1.184, 0.848)],
        [(f64::NAN, f64::NAN), (1.048, 0.534), (1.180, 0.816)],
        [(f64::NAN, f64::NAN), (1.302, 0.535), (1.175, 0.777)],
        [(f64::NAN, f64::NAN), (f64::NAN, f64::NAN), (1.194, 0.703)],
        [(f64::NAN, f64::NAN), (f64::NAN, f64::NAN), (1.489, 0.702)],
    ];
    T[(2 - alpha) as usize][(d - 1) as usize]
}

/// Greenhall Table 2 (unmodified variances, large r).
fn table2(alpha: i32, d: u32) -> (f64, f64) {
    const T: [[(f64, f64); 3]; 7] = [
        [
            (3.0 / 2.0, 1.0 / 2.0),
            (35.0 / 18.0, 1.0),
            (231.0 / 100.0, 3.0 / 2.0),
        ],
        [(78.6, 25.2), (790.0, 410.0), (9950.0, 6520.0)],
        [
            (2.0 / 3.0, 1.0 / 6.0),
            (2.0 / 3.0, 1.0 / 3.0),
            (7.0 / 9.0, 1.0 / 2.0),
        ],
        [(f64::NAN, f64::NAN), (0.852, 0.375), (0.997, 0.617)],
        [(f64::NAN, f64::NAN), (1.079, 0.368), (1.033, 0.607)],
        [(f64::NAN, f64::NAN), (f64::NAN, f64::NAN), (1.053, 0.553)],
        [(f64::NAN, f64::NAN), (f64::NAN, f64::NAN), (1.302, 0.535)],
    ];
    T[(2 - alpha) as usize][(d - 1) as usize]
}

/// Greenhall Table 3 (flicker PM, unmodified): (b0, b1) of the ln m normalisation.
fn table3(d: u32) -> (f64, f64) {
    [(6.0, 4.0), (15.23, 12.0), (47.8, 40.0)][(d - 1) as usize]
}

/// Quantile of the χ² distribution with `k` degrees of freedom (k > 0, 0 < p < 1; else NaN).
/// Safeguarded Newton iteration on ln x over statrs' regularised-gamma CDF, started from the
/// Wilson–Hilferty approximation: statrs' own inverse stalls where its density overflows
/// (k of a few hundred) and fails for very small or very large k.
pub fn chi2_quantile(p: f64, k: f64) -> f64 {
    let Ok(dist) = ChiSquared::new(k) else {
        return f64::NAN;
    };
    if !(p > 0.0 && p < 1.0) {
        return f64::NAN;
    }
    let g = |u: f64| dist.cdf(u.exp()) - p;
    // Start: Wilson–Hilferty, or the mean where it is not positive.
    let z = Normal::new(0.0, 1.0).map_or(0.0, |n| n.inverse_cdf(p));
    let c = 2.0 / (9.0 * k);
    let wh = k * (1.0 - c + z * c.sqrt()).powi(3);
    let mut u = if wh > 0.0 { wh.ln() } else { k.ln() };
    // Bracket the root in ln x.
    let (mut lo, mut hi) = (u, u);
    let mut step = 0.5;
    while g(lo) > 0.0 {
        lo -= step;
        step *= 2.0;
        if lo < -1e3 {
            return 0.0;
        }
    }
    step = 0.5;
    while g(hi) < 0.0 {
        hi += step;
        step *= 2.0;
        if hi > 1e3 {
            return f64::INFINITY;
        }
    }
    u = u.clamp(lo, hi);
    for _ in 0..200 {
        let gu = g(u);
        if gu == 0.0 {
            break;
        }
        if gu < 0.0 {
            lo = u;
        } else {
            hi = u;
        }
        // d/du F(e^u) = f(x)·x, through the log-density (the direct one overflows).
        let slope = (dist.ln_pdf(u.exp()) + u).exp();
        let newton = u - gu / slope;
        let next = if newton > lo && newton < hi && slope > 0.0 {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if (next - u).abs() <= 4.0 * f64::EPSILON * u.abs().max(1.0) || hi - lo <= f64::EPSILON {
            u = next;
            break;
        }
        u = next;
    }
    u.exp()
}

/// Two-sided χ² confidence interval of a deviation `dev` with `edf` degrees of freedom at
/// two-sided `confidence` (e.g. [`CONFIDENCE_1SIGMA`]): (dev·√(edf/χ²_{(1+p)/2}),
/// dev·√(edf/χ²_{(1−p)/2})), SP 1065 Eq. (45) as allantools' `confidence_interval` applies
/// it. NaN bounds for an invalid `edf` or `confidence` outside (0, 1).
pub fn chi2_interval(dev: f64, edf: f64, confidence: f64) -> (f64, f64) {
    let valid = |v: f64, hi: f64| v > 0.0 && v < hi;
    if !valid(confidence, 1.0) || !valid(edf, f64::INFINITY) {
        return (f64::NAN, f64::NAN);
    }
    let tail = (1.0 - confidence) / 2.0;
    let chi_lo = chi2_quantile(tail, edf);
    let chi_hi = chi2_quantile(1.0 - tail, edf);
    (dev * (edf / chi_hi).sqrt(), dev * (edf / chi_lo).sqrt())
}

/// What a series holds, for noise identification.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeriesKind {
    /// Phase (time error, or integrated angle): decimated by m for identification.
    Phase,
    /// Fractional frequency (or rate): averaged over m for identification.
    Frequency,
}

/// How the noise type of one averaging time was decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseIdMethod {
    /// Lag-1 autocorrelation after `d` differences (Riley & Greenhall 2004).
    Lag1Acf {
        /// Number of differences taken before the autocorrelation fell below 1/4 (or dmax).
        d: u32,
    },
    /// Ratio B1 of the standard to the Allan variance (Howe, Beard, Greenhall, Riley 2000),
    /// used with fewer than [`LAG1_MIN_POINTS`] values.
    B1Ratio,
    /// Given by the caller.
    Fixed,
    /// Too few values even for B1 (under 3 averages): white FM assumed.
    Assumed,
}

/// A power-law noise identification at one averaging factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseId {
    /// Dominant alpha, rounded (SP 1065 convention; may lie outside −2..=2).
    pub alpha: i32,
    /// Unrounded estimate p (+2 for phase data) of the lag-1 method; NaN for B1.
    pub alpha_est: f64,
    /// Method that decided.
    pub method: NoiseIdMethod,
}

/// Identifies the dominant power-law noise of `data` at averaging factor `m` as Stable32
/// does: the lag-1 autocorrelation method when at least [`LAG1_MIN_POINTS`] decimated
/// (phase) or averaged (frequency) values remain, else the B1 ratio. `dmax` is 2 for the
/// Allan, 3 for the Hadamard variance. `None` below three averages or for m = 0.
pub fn noise_id(data: &[f64], kind: SeriesKind, m: usize, dmax: u32) -> Option<NoiseId> {
    lag1_noise_id(data, kind, m, dmax).or_else(|| b1_noise_id(data, kind, m))
}

/// Lag-1 autocorrelation identification (allantools `autocorr_noise_id`, dmin = 0): phase
/// data are decimated by m and a quadratic removed, frequency data averaged over m and a
/// line removed; the series is differenced until δ = r1/(1 + r1) < 1/4 or d = `dmax`, and
/// alpha = −round(2δ) − 2d (+2 for phase). `None` with fewer than [`LAG1_MIN_POINTS`]
/// values.
pub fn lag1_noise_id(data: &[f64], kind: SeriesKind, m: usize, dmax: u32) -> Option<NoiseId> {
    if m == 0 {
        return None;
    }
    let (mut z, add) = match kind {
        SeriesKind::Phase => {
            let x: Vec<f64> = data.iter().step_by(m).copied().collect();
            (detrend(&x, 2), 2)
        }
        SeriesKind::Frequency => {
            let y: Vec<f64> = data
                .chunks_exact(m)
                .map(|c| c.iter().sum::<f64>() / m as f64)
                .collect();
            (detrend(&y, 1), 0)
        }
    };
    if z.len() < LAG1_MIN_POINTS {
        return None;
    }
    let mut d = 0u32;
    loop {
        let r1 = lag1_acf(&z);
        let delta = r1 / (1.0 + r1);
        if delta < 0.25 || d >= dmax {
            let df = f64::from(d);
            // numpy's round: halves go to the even neighbour.
            // Bounded before the cast: r1 → −1 sends δ to −∞.
            let alpha = (-(2.0 * delta).round_ties_even() - 2.0 * df).clamp(-16.0, 16.0);
            return Some(NoiseId {
                alpha: alpha as i32 + add,
                alpha_est: -2.0 * (delta + df) + f64::from(add),
                method: NoiseIdMethod::Lag1Acf { d },
            });
        }
        z = z.windows(2).map(|w| w[1] - w[0]).collect();
        d += 1;
    }
}

/// B1-ratio identification: B1 = (sample variance of the N τ-averaged frequencies) / (their
/// Allan variance), compared with its expectation for μ = 1, 0, −1, −2 (random-walk FM,
/// flicker FM, white FM, PM) at the geometric-mean boundaries. B1 cannot tell white from
/// flicker PM; μ = −2 is reported as flicker PM (alpha 1), the label Stable32 gives such
/// averaging times in its PHASE.DAT run. `None` below N = 3.
pub fn b1_noise_id(data: &[f64], kind: SeriesKind, m: usize) -> Option<NoiseId> {
    if m == 0 {
        return None;
    }
    let freq: Vec<f64> = match kind {
        SeriesKind::Phase => data.windows(2).map(|w| w[1] - w[0]).collect(),
        SeriesKind::Frequency => data.to_vec(),
    };
    let avg: Vec<f64> = freq
        .chunks_exact(m)
        .map(|c| c.iter().sum::<f64>() / m as f64)
        .collect();
    let n = avg.len();
    if n < 3 {
        return None;
    }
    let nf = n as f64;
    let mean = avg.iter().sum::<f64>() / nf;
    let svar = avg.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (nf - 1.0);
    let avar = avg.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (nf - 1.0));
    if avar.is_nan() || avar <= 0.0 {
        return None;
    }
    let b1 = svar / avar;
    let expected = |mu: i32| match mu {
        1 => nf / 2.0,
        0 => nf * nf.ln() / (2.0 * (nf - 1.0) * std::f64::consts::LN_2),
        -1 => 1.0,
        _ => (nf * nf - 1.0) / (1.5 * nf * (nf - 1.0)),
    };
    let mu = [1, 0, -1]
        .into_iter()
        .find(|&mu| b1 > (expected(mu) * expected(mu - 1)).sqrt())
        .unwrap_or(-2);
    // α = −μ − 1 for the FM types; μ = −2 (PM) is ambiguous, see above.
    let alpha = if mu == -2 { 1 } else { -mu - 1 };
    Some(NoiseId {
        alpha,
        alpha_est: f64::NAN,
        method: NoiseIdMethod::B1Ratio,
    })
}

/// Lag-1 autocorrelation Σ(x_i − x̄)(x_{i+1} − x̄) / Σ(x_i − x̄)² (Riley 2004, Eq. 2).
fn lag1_acf(x: &[f64]) -> f64 {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let num: f64 = x.windows(2).map(|w| (w[0] - mean) * (w[1] - mean)).sum();
    let den: f64 = x.iter().map(|v| (v - mean).powi(2)).sum();
    num / den
}

/// Residual of the least-squares polynomial of degree `deg` (1 or 2) in the sample index.
/// The abscissa is centred and scaled to [−1, 1] so the normal equations stay well posed.
fn detrend(x: &[f64], deg: usize) -> Vec<f64> {
    let n = x.len();
    if n <= deg {
        return vec![0.0; n];
    }
    let c = (n as f64 - 1.0) / 2.0;
    let h = c.max(1.0);
    let u = |i: usize| (i as f64 - c) / h;
    let k = deg + 1;
    let mut a = vec![vec![0.0f64; k + 1]; k];
    for (i, &xi) in x.iter().enumerate() {
        let ui = u(i);
        let pw: Vec<f64> = (0..k).map(|p| ui.powi(p as i32)).collect();
        for r in 0..k {
            for cc in 0..k {
                a[r][cc] += pw[r] * pw[cc];
            }
            a[r][k] += pw[r] * xi;
        }
    }
    // Gaussian elimination with partial pivoting on the (k × k+1) augmented system.
    for col in 0..k {
        let piv = (col..k)
            .max_by(|&p, &q| a[p][col].abs().total_cmp(&a[q][col].abs()))
            .unwrap_or(col);
        a.swap(col, piv);
        let (top, below) = a.split_at_mut(col + 1);
        let pivot_row = &top[col];
        for row in below {
            let f = row[col] / pivot_row[col];
            for (v, p) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                *v -= f * p;
            }
        }
    }
    let mut coef = vec![0.0; k];
    for r in (0..k).rev() {
        let s: f64 = (r + 1..k).map(|cc| a[r][cc] * coef[cc]).sum();
        coef[r] = (a[r][k] - s) / a[r][r];
    }
    x.iter()
        .enumerate()
        .map(|(i, &xi)| {
            let ui = u(i);
            xi - (0..k).map(|p| coef[p] * ui.powi(p as i32)).sum::<f64>()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn gauss(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| <StandardNormal as Distribution<f64>>::sample(&StandardNormal, &mut rng))
            .collect()
    }

    /// White FM at m = 1 in Greenhall's model: the phase is Brownian motion averaged over τ0,
    /// so y_k = x̄_{k+1} − x̄_k has the triangular kernel (variance 2/3, lag-1 covariance 1/6)
    /// and the second differences z_k = y_{k+1} − y_k have correlations ρ1 = −1/3,
    /// ρ2 = −1/6, ρ≥3 = 0. The EDF of Σz² over M = N − 2 terms is therefore exactly
    /// M / (1 + 2(1 − 1/M)ρ1² + 2(1 − 2/M)ρ2²) → 18M/23 for large N.
    #[test]
    fn white_fm_m1_edf_matches_closed_form() {
        for n in [50usize, 1001, 100_000, 10_000_000] {
            let big_m = (n - 2) as f64;
            let inv =
                (1.0 + 2.0 * (1.0 - 1.0 / big_m) / 9.0 + 2.0 * (1.0 - 2.0 / big_m) / 36.0) / big_m;
            let edf = edf_overlapping_adev(0, 2, 1, n);
            assert!(
                (edf * inv - 1.0).abs() < 1e-12,
                "n={n}: {edf} vs {}",
                1.0 / inv
            );
        }
        let edf = edf_overlapping_adev(0, 2, 1, 10_000_002);
        assert!((edf / 1e7 - 18.0 / 23.0).abs() < 1e-6);
    }

    /// White PM, independent phase samples: the second differences at lag i·m correlate as
    /// C(4, 2−i)/C(4, 2) = −2/3, 1/6, so for r = M/m ≥ 3,
    /// 1/edf = (1 + 2(1 − 1/r)(4/9) + 2(1 − 2/r)(1/36))/M = (35/18 − 1/r)/M; with r ≤ 2 only
    /// the lags that fit remain.
    #[test]
    fn white_pm_edf_matches_closed_form() {
        let (m, n) = (10usize, 1000usize);
        let big_m = (n - 2 * m) as f64;
        let r = big_m / m as f64;
        let expect = big_m / (35.0 / 18.0 - 1.0 / r);
        assert!((edf_overlapping_adev(2, 2, m, n) / expect - 1.0).abs() < 1e-12);
        // N = 35, m = 10: M = 15, r = 1.5, one lag: 1/edf = (1 + 2·(1 − 1/1.5)·(4/9))/15.
        let expect = 15.0 / (1.0 + 2.0 * (1.0 - 1.0 / 1.5) * 4.0 / 9.0);
        assert!((edf_overlapping_adev(2, 2, 10, 35) / expect - 1.0).abs() < 1e-12);
    }

    /// Reference EDFs printed by allantools 2024.6 `edf_greenhall(alpha, d=2, m, N,
    /// overlapping=True, modified=False)`, one per branch of the algorithm (2.1a, 2.1b, 2.2,
    /// 2.3, 3.1, 3.2, 3.3, 4.2) and noise type.
    #[test]
    fn edf_matches_allantools_branches() {
        let cases: [(i32, usize, usize, f64); 14] = [
            (0, 1, 1001, 782.030_299_072_743_8),
            (0, 32, 1001, 43.351_181_324_065_75),
            (0, 128, 1001, 9.550_953_331_497_8),
            (0, 300, 1001, 3.156_716_789_973_102_3),
            (-1, 16, 10001, 728.780_129_674_537_2),
            (-1, 40, 10001, 291.626_670_539_763_7),
            (-2, 8, 10001, 1_152.985_723_184_942_1),
            (-2, 512, 10001, 16.571_849_409_774_426),
            (-2, 3000, 10001, 1.661_197_131_445_458_6),
            (1, 4, 10001, 3_906.337_853_042_425),
            (1, 64, 10001, 831.296_092_293_500_6),
            (1, 3000, 10001, 34.137_504_684_273_19),
            (2, 16, 10001, 5_131.149_618_360_024),
            (2, 1000, 10001, 4_397.458_423_493_045),
        ];
        for (alpha, m, n, expect) in cases {
            let edf = edf_overlapping_adev(alpha, 2, m, n);
            assert!(
                (edf / expect - 1.0).abs() < 1e-9,
                "alpha={alpha} m={m} n={n}: {edf} vs {expect}"
            );
        }
    }

    /// The other estimators of `edf_greenhall` (modified, non-overlapping, Hadamard) against
    /// allantools 2024.6 (branches 1.1, 1.2, 1.3, 3.1 and 2.1a with d = 3).
    #[test]
    fn edf_matches_allantools_other_estimators() {
        let cases: [(i32, u32, usize, usize, bool, bool, f64); 5] = [
            (0, 2, 4, 1001, true, true, 239.995_772_189_568_24),
            (0, 2, 64, 10001, true, true, 148.955_585_860_240_86),
            (0, 2, 40, 220, true, true, 3.184_416_809_052_016),
            (1, 3, 8, 1001, false, false, 55.947_129_768_590_53),
            (-3, 3, 16, 10001, true, false, 590.815_035_987_357_2),
        ];
        for (alpha, d, m, n, ov, md, expect) in cases {
            let edf = edf_greenhall(alpha, d, m, n, ov, md);
            assert!(
                (edf / expect - 1.0).abs() < 1e-9,
                "alpha={alpha} d={d} m={m} n={n}: {edf} vs {expect}"
            );
        }
        // Modified estimator whose filter (m + d·m points) does not fit.
        assert!(edf_greenhall(-1, 2, 400, 1001, true, true).is_nan());
    }

    #[test]
    fn edf_rejects_undefined_estimators() {
        assert!(edf_overlapping_adev(-3, 2, 4, 1000).is_nan());
        assert!(edf_overlapping_adev(3, 2, 4, 1000).is_nan());
        assert!(edf_overlapping_adev(0, 2, 0, 1000).is_nan());
        assert!(edf_overlapping_adev(0, 2, 10, 20).is_nan());
        assert!(edf_overlapping_adev(0, 4, 1, 1000).is_nan());
        assert!(edf_overlapping_adev(-3, 3, 4, 1000).is_finite());
    }

    /// χ² quantiles against scipy.stats.chi2.ppf (scipy 1.17), and the interval's basic
    /// properties.
    #[test]
    fn chi2_quantiles_and_interval() {
        let tail = (1.0 - CONFIDENCE_1SIGMA) / 2.0;
        let cases = [
            (0.05, 10.0, 3.940_299_136_119_060_5),
            (0.95, 10.0, 18.307_038_053_275_146),
            (tail, 1.0, 0.040_069_504_633_640_94),
            (1.0 - tail, 1.0, 1.986_996_713_315_955),
            (tail, 782.030_299_072_743_8, 742.498_989_156_828_3),
            (1.0 - tail, 782.030_299_072_743_8, 821.561_684_805_495_7),
            (tail, 1e6, 998_585.786_909_061_1),
            (1.0 - tail, 1.2, 2.351_998_691_802_232),
            // Where statrs' own inverse stalls or fails.
            (tail, 288.152_061_085_805_5, 264.173_604_432_269_6),
            (0.025, 0.3, 2.630_074_356_629_365_5e-11),
            (1.0 - tail, 1e7, 10_004_472.135_805_931),
        ];
        for (p, k, expect) in cases {
            let q = chi2_quantile(p, k);
            assert!(
                (q / expect - 1.0).abs() < 1e-10,
                "p={p} k={k}: {q} vs {expect}"
            );
        }
        let (lo, hi) = chi2_interval(2.0, 50.0, CONFIDENCE_1SIGMA);
        assert!(lo < 2.0 && hi > 2.0);
        assert!(chi2_interval(1.0, 10.0, 1.0).0.is_nan());
        assert!(chi2_interval(1.0, f64::NAN, 0.5).1.is_nan());
    }

    /// Pure noises of each type are identified at short and long averaging factors, from
    /// frequency and from phase data.
    #[test]
    fn noise_id_recognises_pure_noises() {
        let n = 40_000;
        let white = gauss(n + 1, 3);
        // White PM as frequency: first differences of white phase.
        let wpm_freq: Vec<f64> = white.windows(2).map(|w| w[1] - w[0]).collect();
        let wfm = gauss(n, 4);
        let mut acc = 0.0;
        let rwfm: Vec<f64> = gauss(n, 5)
            .into_iter()
            .map(|v| {
                acc += v;
                acc
            })
            .collect();
        for m in [1usize, 4, 16, 64] {
            let id = |y: &[f64]| noise_id(y, SeriesKind::Frequency, m, 2).unwrap().alpha;
            assert_eq!(id(&wpm_freq), 2, "white PM at m={m}");
            assert_eq!(id(&wfm), 0, "white FM at m={m}");
            assert_eq!(id(&rwfm), -2, "random-walk FM at m={m}");
            assert_eq!(
                noise_id(&white, SeriesKind::Phase, m, 2).unwrap().alpha,
                2,
                "white PM phase at m={m}"
            );
        }
        // Long averaging factors fall back to B1 (N = 40000/2000 = 20 averages).
        let b1 = noise_id(&wfm, SeriesKind::Frequency, 2000, 2).unwrap();
        assert_eq!(b1.method, NoiseIdMethod::B1Ratio);
        assert_eq!(b1.alpha, 0);
        let b1 = noise_id(&rwfm, SeriesKind::Frequency, 2000, 2).unwrap();
        assert_eq!(b1.alpha, -2);
        assert!(noise_id(&wfm, SeriesKind::Frequency, 20_000, 2).is_none());
        // Degenerate series: alternating (r1 = −1) and constant.
        let alt: Vec<f64> = (0..100)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        assert!(noise_id(&alt, SeriesKind::Frequency, 1, 2).is_some());
        assert!(noise_id(&[1.0; 100], SeriesKind::Frequency, 1, 2).is_some());
        assert!(noise_id(&[1.0; 100], SeriesKind::Frequency, 40, 2).is_none());
    }

    #[test]
    fn detrend_removes_polynomials_exactly() {
        let x: Vec<f64> = (0..50)
            .map(|i| 3.0 - 0.5 * i as f64 + 0.01 * (i * i) as f64)
            .collect();
        assert!(detrend(&x, 2).iter().all(|r| r.abs() < 1e-12));
        let line: Vec<f64> = (0..50).map(|i| 1.0 + 2.0 * i as f64).collect();
        assert!(detrend(&line, 1).iter().all(|r| r.abs() < 1e-12));
    }
}
