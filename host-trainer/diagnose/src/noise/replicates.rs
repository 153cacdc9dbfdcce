//! Replicates of the fitted gyro noise for the parametric bootstraps, simulated with the
//! simulator's generator: not an AR(p) bootstrap, which cannot reproduce the bank's slow
//! wander (correlation times up to 10⁴ s) and gives false alarms on most no-effect
//! recordings.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use rlg_simulate::noise::{NoiseGen, NoiseParams};

/// `nb` means of `block_s`-second blocks of gyro noise with parameters `p`, simulated by the
/// simulator's generator: the white part exactly (σ/√samples per block), the coloured part
/// stepped every tenth of a block and averaged (its correlation times are ≥ 100 s).
pub fn simulate_block_means(
    p: &NoiseParams,
    nb: usize,
    block_s: f64,
    rng: &mut ChaCha8Rng,
    seed: u64,
) -> Vec<f64> {
    let white = p.arw_dph_rt_h * 60.0 / block_s.sqrt();
    let coloured = NoiseParams {
        arw_dph_rt_h: 0.0,
        angle_quantum_arcsec: 0.0,
        ..p.clone()
    };
    let mut g = NoiseGen::new(&coloured, seed);
    let sub = 10;
    let h = block_s / sub as f64;
    (0..nb)
        .map(|_| {
            let c: f64 = (0..sub).map(|_| g.step(h, 1.0)).sum::<f64>() / sub as f64;
            let z: f64 = StandardNormal.sample(rng);
            c + white * z
        })
        .collect()
}

/// As [`simulate_block_means`], with each block's white variance scaled by `white_level`
/// (one multiplier a block, mean 1) where the white level changes in time; the coloured part
/// is drawn as there, from the same generators.
pub fn simulate_block_means_levelled(
    p: &NoiseParams,
    white_level: Option<&[f64]>,
    nb: usize,
    block_s: f64,
    rng: &mut ChaCha8Rng,
    seed: u64,
) -> Vec<f64> {
    let Some(w) = white_level else {
        return simulate_block_means(p, nb, block_s, rng, seed);
    };
    let white = p.arw_dph_rt_h * 60.0 / block_s.sqrt();
    let coloured = NoiseParams {
        arw_dph_rt_h: 0.0,
        ..p.clone()
    };
    let mut x = simulate_block_means(&coloured, nb, block_s, rng, seed);
    for (v, wb) in x.iter_mut().zip(w) {
        let z: f64 = StandardNormal.sample(rng);
        *v += white * wb.sqrt() * z;
    }
    x
}

/// A deterministic generator for replicate `k` of a bootstrap seeded by `seed`.
pub fn replicate_rng(seed: u64, k: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(k);
    r
}
