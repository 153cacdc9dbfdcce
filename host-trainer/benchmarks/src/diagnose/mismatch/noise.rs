//! The mismatched set's gyro noise: white (Gaussian or Student-t), a bank of Gauss–Markov
//! processes (a 1/f-like one over four decades or a short one), rate random walk, angle
//! quantisation and spikes; generated sample by sample, and the exact covariance of its
//! 100 s means as a dense matrix.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal, StudentT};
use serde::Serialize;

use super::{log_uni, uni};
use rlg_diagnose::linalg::{centred, dot};
use rlg_eval::metrics::allan::FLICKER_FLOOR;
use rlg_simulate::noise::bank_peak_adev;

/// The paper's angle random walk, °/√h.
pub(super) const PAPER_ARW: f64 = 2.5e-4;
/// The paper's bias instability, °/h.
pub(super) const PAPER_BI: f64 = 5e-4;

/// One gyro's noise.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NoiseDraw {
    /// Angle random walk N, °/√h (white σ of a sample N·60/√dt °/h).
    pub arw_dph_rt_h: f64,
    /// White samples are Student-t with 3 degrees of freedom (same variance).
    pub student_t: bool,
    /// Bias instability B, °/h: the bank's Allan deviation peaks at 0.664·B.
    pub bias_instability_dph: f64,
    /// The bank is the 1/f-like one (12–20 processes over four decades).
    pub one_over_f: bool,
    /// Correlation times of the Gauss–Markov bank, s.
    pub gm_tau_s: Vec<f64>,
    /// Common steady-state σ of its processes, °/h.
    pub gm_sigma_dph: f64,
    /// Rate random walk K, °/h/√h (0: none).
    pub rrw_dph_per_rt_h: f64,
    /// Angle quantum, arcsec (0: none).
    pub quantum_arcsec: f64,
    /// Spikes: (sample, size in units of the 1 s σ, signed).
    pub spikes: Vec<(usize, f64)>,
}

/// σ of each process of a bank with correlation times `taus` whose Allan deviation peaks at
/// 0.664·`b` (the peak searched on a log grid from a tenth of the shortest to ten times the
/// longest correlation time).
fn bank_sigma(taus: &[f64], b: f64) -> f64 {
    FLICKER_FLOOR * b / bank_peak_adev(taus, taus[0], taus[taus.len() - 1])
}

/// Expected variance about its own least-squares line of `m` consecutive samples of a unit
/// AR(1) process of coefficient `a`: (m − u₀ᵀRu₀ − u₁ᵀRu₁)/(m − 2), R_ij = a^|i−j|, u₀ and u₁
/// the orthonormal constant and slope (tr R = m; the line takes R's part in their span).
fn gm_block_share(a: f64, m: usize) -> f64 {
    if m < 3 {
        return 0.0;
    }
    let mf = m as f64;
    let mid = (mf - 1.0) / 2.0;
    let norm1 = (0..m).map(|i| (i as f64 - mid).powi(2)).sum::<f64>().sqrt();
    let u1: Vec<f64> = (0..m).map(|i| (i as f64 - mid) / norm1).collect();
    // Quadratic forms over the lags: Σ_ij u_i·u_j·a^|i−j| = Σ_d a^d·c_d, c_0 = Σ u_i²,
    // c_d = 2·Σ_i u_i·u_{i+d}.
    let (mut q0, mut q1, mut p) = (0.0, 0.0, 1.0);
    for d in 0..m {
        let w = if d == 0 { 1.0 } else { 2.0 };
        q0 += w * p * (m - d) as f64 / mf;
        q1 += w * p * (0..m - d).map(|i| u1[i] * u1[i + d]).sum::<f64>();
        p *= a;
    }
    (mf - q0 - q1) / (mf - 2.0)
}

/// `n` correlation times log-spaced from `lo` over `decades`.
pub(super) fn log_spaced(lo: f64, decades: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| lo * 10f64.powf(decades * k as f64 / (n - 1).max(1) as f64))
        .collect()
}

impl NoiseDraw {
    /// Draws a gyro's noise for a record of `n` samples at `dt_s` (see the module doc of
    /// `mismatch`): every part and level is its own draw.
    pub(super) fn draw(rng: &mut ChaCha8Rng, n: usize) -> NoiseDraw {
        let arw = PAPER_ARW * log_uni(rng, 0.5, 2.0);
        let student_t = uni(rng, 0.0, 1.0) < 0.4;
        let b = PAPER_BI * log_uni(rng, 0.5, 2.0);
        let one_over_f = uni(rng, 0.0, 1.0) < 0.5;
        let gm_tau_s = if one_over_f {
            let count = 12 + (uni(rng, 0.0, 9.0) as usize).min(8);
            log_spaced(log_uni(rng, 30.0, 300.0), 4.0, count)
        } else {
            let count = 3 + (uni(rng, 0.0, 4.0) as usize).min(3);
            let decades = uni(rng, 1.0, 3.0);
            log_spaced(log_uni(rng, 50.0, 1000.0), decades, count)
        };
        let gm_sigma_dph = bank_sigma(&gm_tau_s, b);
        // K whose Allan deviation K·√(τ/3 h) at 10⁴ s is 0.3–1.5× the bank's floor.
        let rrw_dph_per_rt_h = if uni(rng, 0.0, 1.0) < 0.4 {
            uni(rng, 0.3, 1.5) * FLICKER_FLOOR * b / (1e4 / 3600.0 / 3.0f64).sqrt()
        } else {
            0.0
        };
        let quantum_arcsec = if uni(rng, 0.0, 1.0) < 0.5 {
            log_uni(rng, 0.02, 0.2)
        } else {
            0.0
        };
        let spikes = if uni(rng, 0.0, 1.0) < 0.3 {
            let count = 1 + (uni(rng, 0.0, 5.0) as usize).min(4);
            (0..count)
                .map(|_| {
                    let at = (uni(rng, 0.0, n as f64) as usize).min(n.saturating_sub(1));
                    let sign = if uni(rng, 0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
                    (at, sign * uni(rng, 20.0, 100.0))
                })
                .collect()
        } else {
            Vec::new()
        };
        NoiseDraw {
            arw_dph_rt_h: arw,
            student_t,
            bias_instability_dph: b,
            one_over_f,
            gm_tau_s,
            gm_sigma_dph,
            rrw_dph_per_rt_h,
            quantum_arcsec,
            spikes,
        }
    }

    /// Every amplitude (white, bank, random walk, quantum) times `k`: the block-mean
    /// covariance scales by k².
    pub(super) fn scaled(&self, k: f64) -> NoiseDraw {
        NoiseDraw {
            arw_dph_rt_h: self.arw_dph_rt_h * k,
            bias_instability_dph: self.bias_instability_dph * k,
            gm_sigma_dph: self.gm_sigma_dph * k,
            rrw_dph_per_rt_h: self.rrw_dph_per_rt_h * k,
            quantum_arcsec: self.quantum_arcsec * k,
            ..self.clone()
        }
    }

    /// σ of a white sample, °/h.
    pub(super) fn white_sigma(&self, dt_s: f64) -> f64 {
        self.arw_dph_rt_h * 60.0 / dt_s.sqrt()
    }

    /// The part of a sample's expected variance about its block's line (blocks of `block`
    /// samples of `dt_s`) that is not the white noise, (°/h)²: the angle count's Q²/6 and
    /// the bank's ([`gm_block_share`]); the random walk's is negligible inside a block.
    pub(super) fn unscaled_line_variance(&self, dt_s: f64, block: usize) -> f64 {
        let q = self.quantum_arcsec / dt_s;
        let bank: f64 = self
            .gm_tau_s
            .iter()
            .map(|t| gm_block_share((-dt_s / t).exp(), block))
            .sum();
        q * q / 6.0 + self.gm_sigma_dph.powi(2) * bank
    }

    /// Detectability of a `heteroscedastic` term (the white σ times 1 + k·((T − ref)/30)²) on
    /// 1 Hz samples at `temp_c` (°C, one per sample of `dt_s`) with this noise: the best
    /// test's signal-to-noise ratio, the noise known, D² = I·Σ (g_i − ḡ)² with
    /// g_i = ln(w²·(1 + k·x_i)² + v) the log-variance of a sample about its block's line
    /// (blocks of `block` samples). v is what the term does not scale
    /// ([`NoiseDraw::unscaled_line_variance`]): the angle count's Q²/6 per sample (the
    /// variance of a difference of two uniform phases, averaged over where the rate falls
    /// between counts) and the bank's variance about each block's line.
    ///
    /// I is the Fisher information of a sample's log-variance: ½ for a Gaussian sample,
    /// ¼ for Student-t of 3 degrees of freedom (2ν/(ν + 3)/4), interpolated by the white
    /// part's mean share of the variance when the white part is t3 and the rest is not (no
    /// closed form exists for the sum). The count's part is taken as noise of its variance:
    /// being a difference of phases its spectrum vanishes at low frequencies, so sums of
    /// samples see less of it (the diagnosis sums where the noise is a small fraction of a
    /// count), and this D is that of the samples' variances.
    ///
    /// The diagnosis' own [`heteroscedastic_detectability`] is this with v = 0 and I = ½:
    /// true of the matched simulator, not of a counted or heavy-tailed output, where it
    /// overstates D (under a coarse quantum the white part can be a twentieth of a sample's
    /// variance).
    ///
    /// [`heteroscedastic_detectability`]: rlg_diagnose::variance::heteroscedastic_detectability
    pub(super) fn scale_detectability(
        &self,
        temp_c: &[f64],
        k: f64,
        ref_c: f64,
        dt_s: f64,
        block: usize,
    ) -> f64 {
        let w2 = self.white_sigma(dt_s).powi(2);
        let v = self.unscaled_line_variance(dt_s, block);
        // The scaled white part's variance at each sample.
        let white: Vec<f64> = temp_c
            .iter()
            .map(|t| {
                let s = 1.0 + k * ((t - ref_c) / 30.0).powi(2);
                w2 * s * s
            })
            .collect();
        let g: Vec<f64> = white.iter().map(|x| (x + v).ln()).collect();
        let info = if self.student_t {
            let share = white.iter().map(|x| x / (x + v)).sum::<f64>() / white.len().max(1) as f64;
            0.5 - 0.25 * share
        } else {
            0.5
        };
        let g = centred(&g);
        (info * dot(&g, &g)).sqrt()
    }

    /// σ of one sample of the stationary part (white and bank), °/h.
    pub(super) fn sigma1(&self, dt_s: f64) -> f64 {
        let w = self.white_sigma(dt_s);
        (w * w + self.gm_tau_s.len() as f64 * self.gm_sigma_dph.powi(2)).sqrt()
    }

    /// The recorded rate: `clean` (°/h per sample) plus the noise, the white part times
    /// `white_scale` where given, then counted in whole angle quanta. Seeded by `seed`, one
    /// ChaCha8 stream per part, so a scaled draw is the same realisation scaled.
    pub(super) fn generate(
        &self,
        clean: &[f64],
        white_scale: Option<&[f64]>,
        dt_s: f64,
        seed: u64,
    ) -> Vec<f64> {
        let stream = |k: u64| {
            let mut r = ChaCha8Rng::seed_from_u64(seed);
            r.set_stream(k);
            r
        };
        let (mut rw, mut rg, mut rr, mut rq) = (stream(1), stream(2), stream(3), stream(4));
        let normal = |r: &mut ChaCha8Rng| -> f64 { StandardNormal.sample(r) };
        let t3 = StudentT::new(3.0).ok();
        let sw = self.white_sigma(dt_s);
        let a: Vec<f64> = self.gm_tau_s.iter().map(|t| (-dt_s / t).exp()).collect();
        let s = self.gm_sigma_dph;
        let mut gm: Vec<f64> = a.iter().map(|_| s * normal(&mut rg)).collect();
        let rrw_step = self.rrw_dph_per_rt_h / 60.0 * dt_s.sqrt();
        let mut rrw = 0.0;
        let s1 = self.sigma1(dt_s);
        let mut spike = vec![0.0; clean.len()];
        for (i, v) in &self.spikes {
            if let Some(x) = spike.get_mut(*i) {
                *x += v * s1;
            }
        }
        let q = self.quantum_arcsec;
        // The counter's phase at the first sample is arbitrary: the angle not yet counted
        // starts uniform in [0, Q).
        let mut angle = if q > 0.0 { q * rq.random::<f64>() } else { 0.0 };
        let mut counted = 0.0;
        let mut out = Vec::with_capacity(clean.len());
        for (i, c) in clean.iter().enumerate() {
            let z = match (&t3, self.student_t) {
                (Some(t), true) => t.sample(&mut rw) / 3f64.sqrt(),
                _ => normal(&mut rw),
            };
            let scale = white_scale.map_or(1.0, |w| w[i]);
            let mut v = c + sw * scale * z + spike[i];
            for (x, ak) in gm.iter_mut().zip(&a) {
                // Exact AR(1) step of the process: x ← a·x + σ·√(1 − a²)·z, a = e^(−dt/τ).
                *x = ak * *x + s * (1.0 - ak * ak).sqrt() * normal(&mut rg);
                v += *x;
            }
            if i > 0 && rrw_step > 0.0 {
                rrw += rrw_step * normal(&mut rr);
            }
            v += rrw;
            if q > 0.0 {
                // °/h·s is arcsec: count the accumulated angle in whole quanta.
                angle += v * dt_s;
                let now = (angle / q).floor() * q;
                out.push((now - counted) / dt_s);
                counted = now;
            } else {
                out.push(v);
            }
        }
        out
    }

    /// Covariance (°/h)² of the means of `nb` consecutive blocks of `m` samples, the first
    /// starting at sample `first`, as a dense row-major nb×nb matrix: exactly what
    /// [`NoiseDraw::generate`] makes, spikes left out. White: σ²/m on the diagonal (the
    /// t-distribution scaled to the same variance). Each Gauss–Markov process (discrete
    /// AR(1), a = e^(−dt/τ), variance s²): lag 0 s²/m²·(m + 2·Σ_{d<m}(m − d)·a^d), lag k ≥ 1
    /// s²/m²·a^((k−1)m+1)·S², S = Σ_{d<m} a^d (sums, not the closed forms, which cancel
    /// badly for τ ≫ m·dt). Angle quantisation: a block mean's error is
    /// (e_start − e_end)/(m·dt) with e uniform in [0, Q) and shared by neighbouring blocks:
    /// variance 2·Q²/12/(m·dt)², lag-1 covariance −Q²/12/(m·dt)². Rate random walk (zero at
    /// sample 0, variance q·dt·j at sample j, q = (K/60)² (°/h)²/s), not stationary: for
    /// blocks i < j starting at samples s_i, q·dt·(s_i + (m − 1)/2); on the diagonal
    /// q·dt·(s_i + (m − 1)(2m − 1)/(6m)), the sampled walk's exact value of q·(a_i + L/3).
    pub(super) fn block_cov(&self, nb: usize, m: usize, dt_s: f64, first: usize) -> Vec<f64> {
        let mf = m as f64;
        let mut acov = vec![0.0; nb];
        if let Some(c0) = acov.first_mut() {
            *c0 = self.white_sigma(dt_s).powi(2) / mf;
        }
        let s2 = self.gm_sigma_dph.powi(2) / (mf * mf);
        for tau in &self.gm_tau_s {
            let a = (-dt_s / tau).exp();
            let (mut sum, mut lag0, mut p) = (0.0, mf, 1.0);
            for d in 0..m {
                if d > 0 {
                    lag0 += 2.0 * (mf - d as f64) * p;
                }
                sum += p;
                p *= a;
            }
            for (k, c) in acov.iter_mut().enumerate() {
                *c += if k == 0 {
                    s2 * lag0
                } else {
                    s2 * a.powf(((k - 1) * m + 1) as f64) * sum * sum
                };
            }
        }
        let mut cov = vec![0.0; nb * nb];
        for i in 0..nb {
            for j in 0..nb {
                cov[i * nb + j] = acov[i.abs_diff(j)];
            }
        }
        let qv = self.quantum_arcsec.powi(2) / 12.0 / (mf * dt_s).powi(2);
        if qv > 0.0 {
            for i in 0..nb {
                cov[i * nb + i] += 2.0 * qv;
                if i + 1 < nb {
                    cov[i * nb + i + 1] -= qv;
                    cov[(i + 1) * nb + i] -= qv;
                }
            }
        }
        let q = (self.rrw_dph_per_rt_h / 60.0).powi(2) * dt_s;
        if q > 0.0 {
            for i in 0..nb {
                let si = (first + i * m) as f64;
                cov[i * nb + i] += q * (si + (mf - 1.0) * (2.0 * mf - 1.0) / (6.0 * mf));
                for j in i + 1..nb {
                    let v = q * (si + 0.5 * (mf - 1.0));
                    cov[i * nb + j] += v;
                    cov[j * nb + i] += v;
                }
            }
        }
        cov
    }
}

/// One line on the noise.
pub(super) fn describe_noise(n: &NoiseDraw) -> String {
    let mut parts = vec![format!(
        "{} white ARW {:.1e}",
        if n.student_t { "t3" } else { "Gaussian" },
        n.arw_dph_rt_h
    )];
    if n.quantum_arcsec > 0.0 {
        parts.push(format!("Q {:.3}″", n.quantum_arcsec));
    }
    if n.rrw_dph_per_rt_h > 0.0 {
        parts.push(format!("RRW {:.1e}", n.rrw_dph_per_rt_h));
    }
    let (lo, hi) = (n.gm_tau_s[0], n.gm_tau_s[n.gm_tau_s.len() - 1]);
    parts.push(format!(
        "{} {} GM {lo:.0} s..{hi:.1e} s B {:.1e}",
        if n.one_over_f { "1/f" } else { "bank" },
        n.gm_tau_s.len(),
        n.bias_instability_dph
    ));
    if !n.spikes.is_empty() {
        let k = n.spikes.len();
        parts.push(format!("{k} spike{}", if k == 1 { "" } else { "s" }));
    }
    parts.join(", ")
}
