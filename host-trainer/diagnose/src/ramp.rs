//! Rate ramp or rate random walk: which of the two slow terms of IEEE Std 952 makes the
//! residual's Allan deviation rise at long cluster times.
//!
//! When white noise and bias instability fail the Allan check, the search adds rate random
//! walk K. A drift of the bias (aging, a rate ramp R) fails the same check, and K then takes
//! it: on the mismatched design seeds 5 of 10 agings at detectability ≥ 6 came out
//! `consistent` that way (one, D 9.9, on noise with no rate random walk at all). The two
//! explain the long-τ excess differently: K as a wander of every span, R as one straight
//! line. Each is fitted (K: white + B + K on the baseline; R: white + B on the baseline and
//! a ramp), and the statistic is the difference of their −2 log-likelihoods, each at its own
//! fitted noise parameters with the linear parameters by GLS. Two parametric bootstraps
//! give its distribution under each explanation (K's fitted noise; R's fitted noise plus its
//! fitted ramp). The ramp is preferred when the record's statistic has a p-value of at most
//! α under K, is less probable under K than under R, and the white + B model beside the
//! ramp passes the Allan check itself. The aging candidate is then tested against white + B
//! as on any other record, and every p-value of the diagnosis is at least the one under K:
//! each rests on the choice.

use rayon::prelude::*;

use super::kalman::BlockStateSpace;
use super::linalg::{dot, Basis};
use super::noise::{replicate_rng, simulate_block_means};
use super::reml::{allan_check, reml_noise, AllanCheck};
use rlg_eval::noise::NoiseParams;

/// The fixed-parameter Gaussian likelihood of block means under one noise model, with the
/// fixed effects `cols` profiled by GLS. The Kalman whitening is linear with a gain sequence
/// that does not depend on the data, so the columns are whitened once and each series alone.
struct Fixed {
    ss: BlockStateSpace,
    basis: Basis,
    log_det: f64,
}

impl Fixed {
    fn new(p: &NoiseParams, cols: &[Vec<f64>], block: usize, dt_s: f64) -> Option<Self> {
        let ss = BlockStateSpace::new(p, block, dt_s);
        let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
        let (w, log_det) = ss.whiten(&refs)?;
        Some(Fixed {
            basis: Basis::new(&w),
            ss,
            log_det,
        })
    }

    /// −2 ln L of `y` (without the 2π constant, shared by both models), and its GLS
    /// coefficients.
    fn fit(&self, y: &[f64]) -> Option<(f64, Vec<f64>)> {
        let (w, _) = self.ss.whiten(&[y])?;
        let r = self.basis.residual(&w[0]);
        Some((dot(&r, &r) + self.log_det, self.basis.coefficients(&w[0])))
    }
}

/// The outcome when the ramp is preferred.
#[derive(Clone, Debug)]
pub(crate) struct RampChoice {
    /// White + B fitted beside the ramp.
    pub gyro: NoiseParams,
    /// Its Allan check, on the residual of the baseline and the ramp.
    pub check: Option<AllanCheck>,
    /// Share of rate-random-walk replicates whose statistic favours the ramp as much.
    pub p_rrw: f64,
    /// Share of ramp replicates whose statistic favours rate random walk as much.
    pub p_ramp: f64,
    /// The record's statistic (−2 ln of the likelihood ratio, K over R).
    pub statistic: f64,
}

/// Salt of this test's replicates.
const RAMP_SEED: u64 = 0x7a3b;

/// `Some` when a ramp beside the baseline `base_b` explains the block means `y_b` better
/// than the rate random walk of `rrw`, tested at false-alarm probability `alpha` (see the
/// module doc); `ramp_b` is the ramp's block column, `reps` the replicates of each
/// bootstrap.
#[allow(clippy::too_many_arguments)]
pub(crate) fn ramp_instead_of_rrw(
    base_b: &[Vec<f64>],
    ramp_b: &[f64],
    y_b: &[f64],
    rrw: &NoiseParams,
    block: usize,
    dt_s: f64,
    reps: usize,
    seed: u64,
    alpha: f64,
) -> Option<RampChoice> {
    let nb = y_b.len();
    let block_s = block as f64 * dt_s;
    let mut with_ramp = base_b.to_vec();
    with_ramp.push(ramp_b.to_vec());
    let ramp_noise = reml_noise(&with_ramp, y_b, block, dt_s, false)?;
    let k_model = Fixed::new(rrw, base_b, block, dt_s)?;
    let r_model = Fixed::new(&ramp_noise, &with_ramp, block, dt_s)?;
    let stat = |y: &[f64]| -> Option<f64> { Some(k_model.fit(y)?.0 - r_model.fit(y)?.0) };
    let (r_obs, r_coef) = r_model.fit(y_b)?;
    let t_obs = k_model.fit(y_b)?.0 - r_obs;
    if t_obs <= 0.0 {
        return None;
    }
    let slope = *r_coef.last()?;
    let reps = reps.max(1);
    let draw = |p: &NoiseParams, salt: u64, ramp: f64| -> Vec<f64> {
        (0..reps)
            .into_par_iter()
            .filter_map(|k| {
                let s = seed ^ RAMP_SEED ^ salt;
                let mut y = simulate_block_means(
                    p,
                    nb,
                    block_s,
                    &mut replicate_rng(s, k as u64),
                    s.wrapping_add(k as u64 + 1),
                );
                y.iter_mut().zip(ramp_b).for_each(|(a, r)| *a += ramp * r);
                stat(&y)
            })
            .collect()
    };
    let share = |v: Vec<f64>, extreme: &dyn Fn(f64) -> bool| {
        (1 + v.iter().filter(|t| extreme(**t)).count()) as f64 / (v.len() + 1) as f64
    };
    let p_rrw = share(draw(rrw, 1, 0.0), &|t| t >= t_obs);
    if p_rrw > alpha {
        return None;
    }
    let p_ramp = share(draw(&ramp_noise, 2, slope), &|t| t <= t_obs);
    if p_rrw >= p_ramp {
        return None;
    }
    let ols = Basis::new(&with_ramp);
    let check = allan_check(
        &ramp_noise,
        &ols.residual(y_b),
        block_s,
        |x| ols.residual(x),
        seed,
    );
    if !check.as_ref().is_none_or(AllanCheck::fits) {
        return None;
    }
    Some(RampChoice {
        gyro: ramp_noise,
        check,
        p_rrw,
        p_ramp,
        statistic: t_obs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const NB: usize = 900;
    const BLOCK: usize = 100;

    /// 25 h of 100 s means of `p`, plus a drift of `per_day` °/h per day; the baseline is an
    /// offset, and the rate random walk model is the REML fit with it allowed.
    fn case(p: &NoiseParams, per_day: f64, seed: u64) -> Option<RampChoice> {
        let days: Vec<f64> = (0..NB)
            .map(|b| (b as f64 + 0.5) * BLOCK as f64 / 86_400.0)
            .collect();
        let mut y = simulate_block_means(p, NB, BLOCK as f64, &mut replicate_rng(seed, 0), seed);
        y.iter_mut().zip(&days).for_each(|(v, d)| *v += per_day * d);
        let base = vec![vec![1.0; NB]];
        let rrw = reml_noise(&base, &y, BLOCK, 1.0, true).expect("fits");
        ramp_instead_of_rrw(&base, &days, &y, &rrw, BLOCK, 1.0, 200, seed, 0.02)
    }

    fn white_b() -> NoiseParams {
        NoiseParams {
            arw_dph_rt_h: 3e-4,
            bias_instability_dph: 3e-4,
            ..Default::default()
        }
    }

    /// A drift of 5e-3 °/h per day on white noise and bias instability: the ramp is preferred
    /// to the rate random walk REML fits to it, and the white + B refit passes its Allan check.
    #[test]
    fn a_drift_is_a_ramp_not_rate_random_walk() {
        for seed in 1..=3 {
            let c = case(&white_b(), 5e-3, seed).expect("the ramp is preferred");
            assert!(c.p_rrw <= 0.02 && c.p_rrw < c.p_ramp, "{c:?}");
            assert_eq!(c.gyro.rrw_dph_per_rt_h, 0.0);
        }
    }

    /// Rate random walk with no drift: its wander is not taken for a ramp (an α = 2 % test,
    /// so at most one of ten records may be).
    #[test]
    fn rate_random_walk_is_not_a_ramp() {
        let p = NoiseParams {
            rrw_dph_per_rt_h: 5e-4,
            ..white_b()
        };
        let taken: Vec<u64> = (1..=10).filter(|&s| case(&p, 0.0, s).is_some()).collect();
        assert!(taken.len() <= 1, "taken as a ramp: seeds {taken:?}");
    }
}
