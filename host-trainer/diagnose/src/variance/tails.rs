//! Heavy-tailed white noise: recognising it, and the block log-scale the noise-scale test
//! takes on it instead of the log-variance.

/// Whether the white noise is heavy-tailed: of the samples about their block lines, each
/// block's scaled to unit RMS (so that a scale changing from block to block is not taken for
/// a tail), more than ten times the Gaussian share lie beyond 4 (2·(1 − Φ(4)) = 6.3e-5) and
/// at least 20 do. A few isolated spikes do not make a record heavy-tailed.
pub(super) fn heavy_tailed(rate: &[f64], m: usize, residuals: impl Fn(&[f64]) -> Vec<f64>) -> bool {
    let (mut n, mut beyond) = (0usize, 0usize);
    for r in rate.chunks_exact(m).map(residuals) {
        let rms = (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt();
        if rms > 0.0 {
            n += r.len();
            beyond += r.iter().filter(|v| v.abs() > 4.0 * rms).count();
        }
    }
    beyond >= 20 && beyond as f64 > 10.0 * 6.334e-5 * n as f64
}

/// The block log-scale on heavy-tailed noise: 4·ln of the mean of |e|^½ (twice the log of
/// a scale, as ln v is). On Student-t noise of 3 degrees of freedom, whose fourth moment is
/// infinite, the sample variance's log scatters so widely that the test misses even strong
/// noise scales on such noise, which the ½ power finds; the ½ power keeps 46 % of the
/// Gaussian log-variance's information on t₃ (69 % on Gaussian noise,
/// where the variance is kept). Continuous outputs only (see `from_samples`).
pub(super) fn log_root_scale(r: &[f64]) -> Option<f64> {
    let m = r.iter().map(|v| v.abs().sqrt()).sum::<f64>() / r.len().max(1) as f64;
    (m > 0.0).then(|| 4.0 * m.ln())
}
