//! The noise-scale term's parameters (k, ref) fitted by non-linear least squares on the
//! block log-scales, with their 1σ from the profile of the sum of squares.

use std::sync::atomic::Ordering;

use super::hetero::VarianceTest;
use crate::linalg::{centred, dot};
use crate::minimise::grid_then_golden;
use rlg_physics::Term;

impl VarianceTest {
    /// Residual sum of squares of z about c + 2·ln(1 + k·x(ref)) with c profiled.
    fn rss(&self, k: f64, ref_c: f64) -> f64 {
        let g = self.log_scale(k, ref_c);
        if g.iter().any(|v| v.is_nan()) {
            return f64::INFINITY;
        }
        let d: Vec<f64> = self.z.iter().zip(&g).map(|(a, b)| a - b).collect();
        let dc = centred(&d);
        dot(&dc, &dc)
    }

    /// The smallest k keeping every block's multiplier positive at this reference.
    fn k_floor(&self, ref_c: f64) -> f64 {
        let xmax = self
            .temp
            .iter()
            .map(|t| ((t - ref_c) / 30.0).powi(2))
            .fold(0.0f64, f64::max);
        -0.95 / xmax.max(1e-9)
    }

    /// Best k at a fixed reference: a scan of 80 points over [floor, 20] in asinh scale,
    /// then golden-section refinement; (k, rss).
    fn best_k(&self, ref_c: f64) -> (f64, f64) {
        grid_then_golden(&self.k_grid(ref_c, 80), 60, |k| self.rss(k, ref_c))
    }

    /// `n` values of k over [floor, 20] at this reference, evenly spaced in asinh.
    fn k_grid(&self, ref_c: f64, n: u32) -> Vec<f64> {
        let lo = self.k_floor(ref_c).max(-20.0);
        let (a, b) = (lo.asinh(), 20.0f64.asinh());
        (0..n)
            .map(|i| (a + (b - a) * f64::from(i) / f64::from(n - 1)).sinh())
            .collect()
    }

    /// The smallest rss over the reference at a fixed k: the grid `refs`, then golden-section
    /// refinement within a grid step either side of its best point.
    fn best_ref(&self, k: f64, refs: &[f64]) -> f64 {
        grid_then_golden(refs, 40, |r| self.rss(k, r)).1
    }

    /// The references scanned: 81 points from half the range below the coldest block to
    /// half the range above the hottest.
    fn ref_grid(&self) -> Vec<f64> {
        let (lo, hi) = self
            .temp
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(*t), b.max(*t))
            });
        let r = (hi - lo).max(1.0);
        (0..81)
            .map(|i| lo - 0.5 * r + 2.0 * r * f64::from(i) / 80.0)
            .collect()
    }

    /// The fitted term and its 1σ uncertainties (profile of the sum of squares, Δχ² ≤ 1 with
    /// the residual variance as σ², as for the mean families).
    ///
    /// On an undithered count the σ at the reference is fitted too: the σ fitted under
    /// constant noise is the record's average, and held there it biased k low (k 0.35 for a
    /// true 1.0 in `noise_scale_on_counts_is_found`). k and that σ trade against each other
    /// (alternating fits crept to the optimum over ten rounds), so k is fitted on its profile
    /// with σ minimised at each k, at the reference found first, and its uncertainty read
    /// from that profile.
    pub fn fit(&self) -> (Term, Vec<(&'static str, f64)>) {
        let Some(c) = &self.quant else {
            return self.fit_at_s();
        };
        let (first, unc0) = self.fit_at_s();
        let Term::Heteroscedastic { ref_c, .. } = first else {
            return (first, unc0);
        };
        let s0 = c.s;
        // The best σ at k (log grid over a factor 4 either side, then golden section).
        let sigma_at = |k: f64| {
            let grid: Vec<f64> = (0..41)
                .map(|i| s0 * 4f64.powf((f64::from(i) - 20.0) / 20.0))
                .collect();
            grid_then_golden(&grid, 30, |s| {
                c.s_ref.store(s.to_bits(), Ordering::Relaxed);
                self.rss(k, ref_c)
            })
        };
        let (k, rss_min) = grid_then_golden(&self.k_grid(ref_c, 40), 40, |k| sigma_at(k).1);
        let n = self.z.len() as f64;
        let sigma2 = rss_min / (n - 4.0).max(1.0);
        // The Δχ² ≤ 1 interval of the profile, walked out from k̂ in steps of the conditional
        // uncertainty (at most 60 each way).
        let step = unc0[0].1.max(1e-3 * (1.0 + k.abs()));
        let reach = |dir: f64| {
            (1..=60)
                .map(|j| k + dir * step * f64::from(j))
                .take_while(|kk| sigma_at(*kk).1 - rss_min <= sigma2)
                .last()
                .unwrap_or(k)
        };
        let k_unc = (0.5 * (reach(1.0) - reach(-1.0))).max(0.5 * step);
        let s_hat = sigma_at(k).0;
        c.s_ref.store(s_hat.to_bits(), Ordering::Relaxed);
        let ref_unc = unc0.iter().find(|u| u.0 == "ref_c").map_or(0.0, |u| u.1);
        (
            Term::Heteroscedastic { k, ref_c },
            vec![("k", k_unc), ("ref_c", ref_unc)],
        )
    }

    /// [`Self::fit`] at the count's σ as it stands.
    fn fit_at_s(&self) -> (Term, Vec<(&'static str, f64)>) {
        let refs = self.ref_grid();
        let fits: Vec<(f64, f64)> = refs.iter().map(|r| self.best_k(*r)).collect();
        let j = (0..refs.len())
            .min_by(|&a, &b| fits[a].1.total_cmp(&fits[b].1))
            .unwrap_or(0);
        // Fine grid around the best reference.
        let step = refs[1] - refs[0];
        let fine: Vec<f64> = (-10..=10)
            .map(|a| refs[j] + step * f64::from(a) / 10.0)
            .collect();
        let ffits: Vec<(f64, f64)> = fine.iter().map(|r| self.best_k(*r)).collect();
        let jf = (0..fine.len())
            .min_by(|&a, &b| ffits[a].1.total_cmp(&ffits[b].1))
            .unwrap_or(10);
        let (ref_c, (k, rss_min)) = (fine[jf], ffits[jf]);
        let n = self.z.len() as f64;
        let sigma2 = rss_min / (n - 3.0).max(1.0);
        // Profile in k: for k on a grid around k̂, the best reference.
        let se_lin = {
            let d: Vec<f64> = match &self.quant {
                None => self
                    .temp
                    .iter()
                    .map(|t| {
                        let x = ((t - ref_c) / 30.0).powi(2);
                        2.0 * x / (1.0 + k * x)
                    })
                    .collect(),
                // The derivative in k by a central difference.
                Some(_) => {
                    let h = 1e-4 * (1.0 + k.abs());
                    let (a, b) = (self.log_scale(k + h, ref_c), self.log_scale(k - h, ref_c));
                    a.iter().zip(&b).map(|(a, b)| (a - b) / (2.0 * h)).collect()
                }
            };
            let dc = centred(&d);
            (sigma2 / dot(&dc, &dc).max(1e-300)).sqrt()
        };
        let all_refs: Vec<f64> = refs.iter().chain(&fine).copied().collect();
        let ks: Vec<f64> = (-20..=20)
            .map(|a| k + se_lin * 0.25 * f64::from(a))
            .collect();
        // The reference minimised exactly at each k: on the grids alone the profile is too
        // high away from k̂ and the interval too narrow (the truth falls within 1σ far less
        // often than 68 %).
        let prof: Vec<f64> = ks.iter().map(|kk| self.best_ref(*kk, &refs)).collect();
        let inside: Vec<f64> = ks
            .iter()
            .zip(&prof)
            .filter(|(_, p)| **p - rss_min <= sigma2)
            .map(|(k, _)| *k)
            .collect();
        let half = |v: &[f64], floor: f64| {
            let (lo, hi) = v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(*x), b.max(*x))
                });
            if v.is_empty() {
                floor
            } else {
                (0.5 * (hi - lo)).max(floor)
            }
        };
        let k_unc = half(&inside, 0.125 * se_lin);
        let ref_inside: Vec<f64> = all_refs
            .iter()
            .zip(fits.iter().chain(&ffits))
            .filter(|(_, f)| f.1 - rss_min <= sigma2)
            .map(|(r, _)| *r)
            .collect();
        let ref_unc = half(&ref_inside, 0.05 * step);
        (
            Term::Heteroscedastic { k, ref_c },
            vec![("k", k_unc), ("ref_c", ref_unc)],
        )
    }
}
