//! Overlapping Allan deviation of a uniformly sampled rate series (IEEE Std 952, Annex C),
//! and the read-off of angle random walk, bias instability and rate random walk.
//!
//! Confidence intervals use the simple approximation of the relative 1σ error of an Allan
//! deviation estimate, 1/√(2·(K − 1)) with K = ⌊n/m⌋ independent clusters (IEEE 952 C.2),
//! not the equivalent-degrees-of-freedom χ² bounds; it is conservative for overlapping
//! estimates at short τ and optimistic for the last one or two octaves.

/// One Allan-deviation estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdevPoint {
    /// Cluster time τ = m·dt, s.
    pub tau_s: f64,
    /// Cluster size m, samples.
    pub m: usize,
    /// Overlapping Allan deviation, in the unit of the rate (°/h).
    pub adev: f64,
    /// 1σ uncertainty of `adev` (same unit), adev/√(2(K − 1)).
    pub err: f64,
}

/// Octave-spaced cluster sizes 1, 2, 4, … up to n/3 (at least two non-overlapping pairs).
pub fn octave_clusters(n: usize) -> Vec<usize> {
    std::iter::successors(Some(1usize), |m| m.checked_mul(2))
        .take_while(|&m| 3 * m <= n)
        .collect()
}

/// Overlapping Allan deviation of `rate` (any unit; 1 sample every `dt_s` seconds) at the
/// cluster sizes `ms` (sizes with fewer than 2m + 1 angle samples are skipped).
///
/// σ²(τ) = Σ_k (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2τ²(N − 2m)), θ the integrated angle with
/// N = n + 1 points; accumulated in f64 with compensated (Neumaier) summation of the angle so
/// multi-day series keep full resolution.
pub fn overlapping_adev(rate: &[f64], dt_s: f64, ms: &[usize]) -> Vec<AdevPoint> {
    // Angle relative to the mean rate: removing the mean leaves the differences unchanged
    // and keeps θ small, so the second differences do not lose digits.
    let n = rate.len();
    if n == 0 || dt_s.is_nan() || dt_s <= 0.0 {
        return Vec::new();
    }
    let mean = rate.iter().sum::<f64>() / n as f64;
    let mut theta = Vec::with_capacity(n + 1);
    let (mut s, mut c) = (0.0f64, 0.0f64);
    theta.push(0.0);
    for &y in rate {
        let v = (y - mean) * dt_s;
        let t = s + v;
        c += if s.abs() >= v.abs() {
            (s - t) + v
        } else {
            (v - t) + s
        };
        s = t;
        theta.push(s + c);
    }
    let big_n = n + 1;
    ms.iter()
        .filter(|&&m| m > 0 && 2 * m < big_n)
        .map(|&m| {
            let terms = big_n - 2 * m;
            let ss: f64 = (0..terms)
                .map(|k| {
                    let d = theta[k + 2 * m] - 2.0 * theta[k + m] + theta[k];
                    d * d
                })
                .sum();
            let tau = m as f64 * dt_s;
            let adev = (ss / (2.0 * tau * tau * terms as f64)).sqrt();
            let k = (n / m) as f64;
            let err = if k > 1.0 {
                adev / (2.0 * (k - 1.0)).sqrt()
            } else {
                f64::INFINITY
            };
            AdevPoint {
                tau_s: tau,
                m,
                adev,
                err,
            }
        })
        .collect()
}

/// Points with τ in [lo, hi] s.
fn in_range(points: &[AdevPoint], tau_range_s: (f64, f64)) -> impl Iterator<Item = &AdevPoint> {
    points
        .iter()
        .filter(move |p| p.tau_s >= tau_range_s.0 && p.tau_s <= tau_range_s.1)
}

/// Geometric mean of `f(p)` over the points in range; `None` when none are.
fn log_mean(
    points: &[AdevPoint],
    tau_range_s: (f64, f64),
    f: impl Fn(&AdevPoint) -> f64,
) -> Option<f64> {
    let v: Vec<f64> = in_range(points, tau_range_s).map(|p| f(p).ln()).collect();
    (!v.is_empty()).then(|| (v.iter().sum::<f64>() / v.len() as f64).exp())
}

/// Angle random walk, °/√h, for a rate in °/h: the τ^−1/2 line σ(τ) = N/√τ fitted (slope
/// fixed, least squares in log σ) to the points in `tau_range_s`, read at τ = 1 h.
pub fn angle_random_walk_dph_rt_h(points: &[AdevPoint], tau_range_s: (f64, f64)) -> Option<f64> {
    log_mean(points, tau_range_s, |p| p.adev * (p.tau_s / 3600.0).sqrt())
}

/// Bias instability, °/h: the flat floor (smallest σ in `tau_range_s`) divided by 0.664
/// (= √(2 ln 2 / π), the flicker-noise Allan floor).
pub fn bias_instability_dph(points: &[AdevPoint], tau_range_s: (f64, f64)) -> Option<f64> {
    in_range(points, tau_range_s)
        .map(|p| p.adev)
        .reduce(f64::min)
        .map(|m| m / FLICKER_FLOOR)
}

/// Rate random walk, °/h/√h: the τ^+1/2 line σ(τ) = K·√(τ/3) fitted to the points in
/// `tau_range_s`, read at τ = 3 h.
pub fn rate_random_walk_dph_per_rt_h(points: &[AdevPoint], tau_range_s: (f64, f64)) -> Option<f64> {
    log_mean(points, tau_range_s, |p| {
        p.adev * (3.0 / (p.tau_s / 3600.0)).sqrt()
    })
}

/// Allan floor of flicker (1/f) rate noise per unit bias instability: √(2 ln 2/π) = 0.664.
pub const FLICKER_FLOOR: f64 = 0.664_282_307_6;

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn white(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                sigma * <StandardNormal as Distribution<f64>>::sample(&StandardNormal, &mut rng)
            })
            .collect()
    }

    /// White rate noise of σ per sample at dt has σ(τ) = σ·√(dt/τ) (closed form); every
    /// octave must agree within 3 of its own 1σ error bars.
    #[test]
    fn white_noise_matches_closed_form() {
        let (n, sigma, dt) = (200_000, 0.02, 1.0);
        let x = white(n, sigma, 11);
        let pts = overlapping_adev(&x, dt, &octave_clusters(n));
        assert!(pts.len() >= 15);
        for p in &pts {
            let expect = sigma * (dt / p.tau_s).sqrt();
            assert!(
                (p.adev - expect).abs() < 3.0 * p.err,
                "τ={} {} vs {}",
                p.tau_s,
                p.adev,
                expect
            );
        }
        // ARW: σ·√dt in °/h·√s → /60 for °/√h.
        let arw = angle_random_walk_dph_rt_h(&pts, (1.0, 1000.0)).unwrap();
        let expect = sigma * dt.sqrt() / 60.0;
        assert!((arw / expect - 1.0).abs() < 0.02, "{arw} vs {expect}");
    }

    /// A pure random walk of the rate, b_k = b_{k−1} + K·√(dt/3600)·z, has σ(τ) = K·√(τ_h/3).
    #[test]
    fn rate_random_walk_matches_closed_form() {
        let (n, k) = (200_000, 0.01);
        let z = white(n, 1.0, 5);
        let mut b = 0.0;
        let x: Vec<f64> = z
            .iter()
            .map(|z| {
                b += k * (1.0f64 / 3600.0).sqrt() * z;
                b
            })
            .collect();
        let pts = overlapping_adev(&x, 1.0, &octave_clusters(n));
        let rrw = rate_random_walk_dph_per_rt_h(&pts, (16.0, 4096.0)).unwrap();
        assert!((rrw / k - 1.0).abs() < 0.1, "{rrw}");
    }

    /// Four samples by hand: rates 1, 3, 2, 6 at 1 s. At m = 1 the Allan variance is half the
    /// mean squared first difference, (2² + 1² + 4²)/(2·3) = 3.5; K = 4 clusters give the
    /// 1σ error √3.5/√(2·3). As the only point in range it is the floor, so the bias
    /// instability is √3.5 / 0.664282.
    #[test]
    fn four_samples_by_hand() {
        let p = overlapping_adev(&[1.0, 3.0, 2.0, 6.0], 1.0, &[1]);
        assert_eq!(p.len(), 1);
        assert!((p[0].adev - 3.5f64.sqrt()).abs() < 1e-15);
        assert!((p[0].err - 3.5f64.sqrt() / 6f64.sqrt()).abs() < 1e-15);
        let bi = bias_instability_dph(&p, (0.5, 2.0)).unwrap();
        assert!((bi - 3.5f64.sqrt() / 0.664_282_307_6).abs() < 1e-12);
    }

    #[test]
    fn degenerate_inputs_give_no_points() {
        assert!(overlapping_adev(&[], 1.0, &[1]).is_empty());
        assert!(overlapping_adev(&[1.0, 2.0], 0.0, &[1]).is_empty());
        assert!(overlapping_adev(&[1.0, 2.0], 1.0, &[1, 2]).len() == 1);
        assert_eq!(octave_clusters(10), vec![1, 2]);
        assert_eq!(bias_instability_dph(&[], (0.0, 1.0)), None);
    }
}
