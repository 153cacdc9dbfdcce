//! The noise-scale test on simulated block variances, counts and heavy tails.

use super::counts::*;
use super::detrend::*;
use super::hetero::*;
use crate::linalg::{centred, Basis};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{ChiSquared, Distribution, StandardNormal};
use rlg_physics::Term;

/// Blocks of 100 white samples whose σ follows the term over a temperature sweep.
fn blocks(k: f64, ref_c: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    blocks_of(k, ref_c, seed, false)
}

/// As [`blocks`]; with `heavy`, Student-t samples of 3 degrees of freedom (a normal over
/// the root of an independent χ²₃/3).
fn blocks_of(k: f64, ref_c: f64, seed: u64, heavy: bool) -> (Vec<f64>, Vec<f64>) {
    let chi = ChiSquared::new(3.0_f64).expect("valid");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let nb = 900;
    let temp: Vec<f64> = (0..nb)
        .map(|b| 20.0 + 30.0 * (f64::from(b) / 150.0).sin())
        .collect();
    let z = temp
        .iter()
        .map(|t| {
            let s = 1.0 + k * ((t - ref_c) / 30.0).powi(2);
            let y: Vec<f64> = (0..100)
                .map(|j| {
                    let mut e: f64 = StandardNormal.sample(&mut rng);
                    if heavy {
                        e /= (chi.sample(&mut rng) / 3.0).sqrt();
                    }
                    0.01 * f64::from(j) + 0.015 * s * e
                })
                .collect();
            line_variance(&y).expect("variance").ln()
        })
        .collect();
    (z, temp)
}

fn test_of(z: Vec<f64>, temp: Vec<f64>) -> VarianceTest {
    let mid = temp.iter().sum::<f64>() / temp.len() as f64;
    let u: Vec<f64> = temp.iter().map(|t| (t - mid) / 30.0).collect();
    let u2: Vec<f64> = u.iter().map(|v| v * v).collect();
    let mut t = VarianceTest {
        z,
        temp,
        perp: Basis::new(&[centred(&u), centred(&u2)]),
        dbic: 0.0,
        quant: None,
        heavy: false,
        degree: 1,
    };
    t.dbic = t.statistic(&t.z);
    t
}

/// 25 h at 1 Hz of a gyro whose bias moves by `coeff` °/h per °C, white noise of σ
/// 0.03 °/h, in a chamber cycling −20 … 60 °C at 1 °C/min with 2 h holds, the body
/// following the air with a 300 s lag (so the ramps bend over a few blocks): the rate
/// and the block temperatures.
fn curving_samples(coeff: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let setpoint = |t: f64| {
        let u = t % 24_000.0;
        if u < 7_200.0 {
            -20.0
        } else if u < 12_000.0 {
            -20.0 + (u - 7_200.0) / 60.0
        } else if u < 19_200.0 {
            60.0
        } else {
            60.0 - (u - 19_200.0) / 60.0
        }
    };
    let mut body = -20.0;
    let (mut rate, mut temp) = (Vec::with_capacity(90_000), Vec::with_capacity(900));
    for b in 0..900 {
        let mut sum = 0.0;
        for j in 0..100 {
            body += (setpoint(f64::from(b * 100 + j)) - body) / 300.0;
            sum += body;
            let e: f64 = StandardNormal.sample(&mut rng);
            rate.push(coeff * (body - 25.0) + 0.03 * e);
        }
        temp.push(sum / 100.0);
    }
    (rate, temp)
}

/// A bias of 100 °/h per °C curves within the blocks where the ramps bend: about each
/// block's line that curvature is a noise scale in temperature (flagged against its own
/// permutations), about the polynomial [`detrend_degree`] picks it is not (5 records
/// each). On white noise, t₃ noise and undithered counts the degree stays 1.
#[test]
fn curvature_within_blocks_is_not_a_noise_scale() {
    for seed in 0..5u64 {
        let (rate, temp) = curving_samples(100.0, 40 + seed);
        let t = VarianceTest::from_samples(&rate, 100, temp.clone()).expect("test");
        assert!(t.detrend_degree() > 1, "seed {seed}");
        assert!(!flagged(&t, seed), "seed {seed}: dbic {}", t.dbic);
        let z: Vec<f64> = rate
            .chunks_exact(100)
            .map(|c| line_variance(c).expect("variance").ln())
            .collect();
        let line = test_of(z, temp);
        assert!(flagged(&line, seed), "seed {seed}: dbic {}", line.dbic);
    }
    let (rate, _) = curving_samples(0.01, 50);
    assert_eq!(detrend_degree(&rate, 100), 1);
    let (rate, _) = t3_samples(0.0, 20.0, 3, 0);
    assert_eq!(detrend_degree(&rate, 100), 1);
    let (rate, _) = counted_blocks(0.25, 0.0, 20.0, 7);
    assert_eq!(detrend_degree(&rate, 100), 1);
}

/// The fit recovers k and the reference within their reported uncertainties (3σ), and
/// the statistic separates the term from constant noise by far more than the bootstrap
/// spread of the null.
#[test]
fn recovers_k_and_reference() {
    let (z, temp) = blocks(0.3, 35.0, 1);
    let t = test_of(z, temp);
    let (term, unc) = t.fit();
    let Term::Heteroscedastic { k, ref_c } = term else {
        panic!("not heteroscedastic")
    };
    assert!((k - 0.3).abs() < 3.0 * unc[0].1, "k {k} ± {}", unc[0].1);
    assert!(
        (ref_c - 35.0).abs() < 3.0 * unc[1].1,
        "ref {ref_c} ± {}",
        unc[1].1
    );
    assert!((k - 0.3).abs() < 0.06, "k {k}");
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let null: Vec<f64> = (0..200).map(|_| t.replicate(&mut rng)).collect();
    let min_null = null.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(t.dbic < min_null - 50.0, "{} vs {min_null}", t.dbic);
    let (r0, r1) = t.heldout(&term);
    assert!(r1 < r0, "held-out {r1} vs {r0}");
}

/// Under constant noise the statistic follows the bootstrap's null: about α of the
/// data sets fall below its α quantile.
#[test]
fn null_is_calibrated() {
    let (z, temp) = blocks(0.0, 20.0, 2);
    let t = test_of(z, temp);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut null: Vec<f64> = (0..400).map(|_| t.replicate(&mut rng)).collect();
    null.sort_by(f64::total_cmp);
    let q10 = null[40];
    let below = (0..60)
        .filter(|s| {
            let (z, temp) = blocks(0.0, 20.0, 100 + s);
            test_of(z, temp).dbic < q10
        })
        .count();
    // Binomial(60, 0.1): mean 6, P(X > 14) < 0.2 %.
    assert!(below <= 14, "{below} of 60 below the 10 % quantile");
}

/// Heavy-tailed white noise (Student t, 3 degrees of freedom) with a constant scale: the
/// permutation null keeps the false-alarm rate near α (60 data sets, 10 % quantile of
/// each one's own 400 permutations). A drawn ln χ²₉₈/98 null keeps it too here (the
/// statistic is a ratio of sums of squares, so the wider scatter of the block variances
/// alone does not move it).
#[test]
fn permutation_null_holds_under_heavy_tails() {
    let mut below = 0;
    for s in 0..60u64 {
        let (z, temp) = blocks_of(0.0, 20.0, 200 + s, true);
        let t = test_of(z, temp);
        let mut rng = ChaCha8Rng::seed_from_u64(s);
        let mut null: Vec<f64> = (0..400).map(|_| t.replicate(&mut rng)).collect();
        null.sort_by(f64::total_cmp);
        below += usize::from(t.dbic < null[40]);
    }
    // Binomial(60, 0.1): mean 6, P(X > 14) < 0.2 %.
    assert!(
        below <= 14,
        "{below} of 60 below the permutation null's 10 % quantile"
    );
}

/// 900 blocks of 100 samples of a rate counted in whole 0.1″ increments (1 s samples, so
/// °/h·s is ″), its bias moving with temperature across several counts, white noise of
/// σ = `s` counts scaled by the term.
fn counted_blocks(s: f64, k: f64, ref_c: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let (rate, temp, _) = counted(
        900,
        s,
        &|b| 20.0 + 30.0 * (b as f64 / 150.0).sin(),
        &|_, t| 1.0 + k * ((t - ref_c) / 30.0).powi(2),
        seed,
    );
    (rate, temp)
}

/// `nb` blocks of 100 samples of a rate counted in whole 0.1″ increments at block
/// temperatures `temp(block)` (°C), the count 0.5″ a sample plus 0.004″ per °C, white noise of
/// σ = `s` counts times `scale(block, temperature)`; (rate, temperatures, block mid-times).
fn counted(
    nb: usize,
    s: f64,
    temp: &dyn Fn(usize) -> f64,
    scale: &dyn Fn(usize, f64) -> f64,
    seed: u64,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let q = 0.1;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let temp: Vec<f64> = (0..nb).map(temp).collect();
    let time_s: Vec<f64> = (0..nb).map(|b| 50.0 + 100.0 * b as f64).collect();
    let (mut angle, mut counted) = (rng.random::<f64>() * q, 0.0f64);
    let mut rate = Vec::with_capacity(100 * nb);
    for (b, t) in temp.iter().enumerate() {
        for _ in 0..100 {
            let e: f64 = StandardNormal.sample(&mut rng);
            angle += 0.5 + 0.004 * (t - 20.0) + s * q * scale(b, *t) * e;
            let c = (angle / q).floor() * q;
            rate.push(c - counted);
            counted = c;
        }
    }
    (rate, temp, time_s)
}

/// Whether the statistic is beyond the 10 % quantile of its own 400 permutations.
fn flagged(t: &VarianceTest, seed: u64) -> bool {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut null: Vec<f64> = (0..400).map(|_| t.replicate(&mut rng)).collect();
    null.sort_by(f64::total_cmp);
    t.dbic < null[40]
}

/// The count's own variance, s² + E[frac(x + n)(1 − frac(x + n))], is the variance of
/// simulated counts' samples (about their block lines) at several rates and noise levels.
#[test]
fn count_variance_is_the_counts_variance() {
    for (s, x) in [
        (0.05, 0.2),
        (0.1, 0.5),
        (0.2, 3.37),
        (0.3, 0.05),
        (0.6, 0.8),
    ] {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (mut angle, mut counted) = (rng.random::<f64>(), 0.0f64);
        let c: Vec<f64> = (0..200_000)
            .map(|_| {
                let e: f64 = StandardNormal.sample(&mut rng);
                angle += x + s * e;
                let n = angle.floor();
                let out = n - counted;
                counted = n;
                out
            })
            .collect();
        let v = c
            .chunks_exact(100)
            .map(|b| line_variance(b).expect("variance"))
            .sum::<f64>()
            / 2000.0;
        let want = count_variance(x, s);
        assert!((v / want - 1.0).abs() < 0.03, "s {s} x {x}: {v} vs {want}");
    }
}

/// On an undithered count with constant noise (σ 0.25 counts), the block variances follow
/// the bias between counts and so temperature; with the count's variance taken out the
/// test keeps near α (40 data sets, each against its own permutations' 10 % quantile).
/// Left in, it flags nearly every set. The test on sums of samples, where the noise is a
/// tenth of a count, keeps near α too (40 more sets, of which it runs on most).
#[test]
fn counts_do_not_make_a_noise_scale() {
    let (mut with, mut without, mut summed, mut runs) = (0, 0, 0, 0);
    for seed in 0..40u64 {
        let (rate, temp) = counted_blocks(0.25, 0.0, 20.0, 300 + seed);
        let t = VarianceTest::from_samples(&rate, 100, temp.clone()).expect("test");
        assert!(t.counts(), "the count is read");
        with += usize::from(flagged(&t, seed));
        let raw: Vec<f64> = rate
            .chunks_exact(100)
            .map(|c| line_variance(c).expect("variance").ln())
            .collect();
        without += usize::from(flagged(&test_of(raw, temp), seed));
        let (rate, temp) = counted_blocks(0.1, 0.0, 20.0, 400 + seed);
        if let Some(t) = VarianceTest::from_samples(&rate, 100, temp) {
            assert!(t.counts());
            runs += 1;
            summed += usize::from(flagged(&t, seed));
        }
    }
    // Not run where a block's sums are all equal or the sums' fitted noise is under
    // `MIN_COUNT_SIGMA`.
    assert!(runs >= 20, "the test ran on {runs} of 40 sets of sums");
    // Binomial(40, 0.1): mean 4, P(X > 10) < 0.3 %.
    assert!(
        with <= 10,
        "{with} of 40 flagged with the count's variance out"
    );
    assert!(summed <= 10, "{summed} of {runs} flagged on sums");
    assert!(without >= 30, "{without} of 40 flagged with it in");
}

/// Where the noise is a small fraction of a count, the samples are summed
/// ([`summed_samples`]): 4 to a sum at 0.2 counts, 7 at 0.16, none at half a count, at
/// most an eighth of the block.
#[test]
fn summing_follows_the_noise() {
    assert_eq!(summed_samples(0.2, 100), 4);
    assert_eq!(summed_samples(0.16, 100), 7);
    assert_eq!(summed_samples(0.5, 100), 1);
    assert_eq!(summed_samples(0.1, 100), 12);
    assert_eq!(summed_samples(0.0, 100), 12);
}

/// A noise scale on an undithered count is still found where the noise reaches across
/// counts (σ 0.2 counts at the reference, twice that at the ends, k 1), and its k comes
/// out near the truth.
#[test]
fn noise_scale_on_counts_is_found() {
    noise_scale_on_counts_of(0.2, 0.15);
}

/// The same on sums of samples where the noise is a tenth of a count at the reference.
#[test]
fn noise_scale_on_summed_counts_is_found() {
    noise_scale_on_counts_of(0.1, 0.15);
}

fn noise_scale_on_counts_of(s: f64, tol: f64) {
    let (rate, temp) = counted_blocks(s, 1.0, 20.0, 7);
    let t = VarianceTest::from_samples(&rate, 100, temp).expect("test");
    assert!(t.counts());
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let null: Vec<f64> = (0..200).map(|_| t.replicate(&mut rng)).collect();
    let min_null = null.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(t.dbic < min_null, "{} vs {min_null}", t.dbic);
    let (term, unc) = t.fit();
    let Term::Heteroscedastic { k, .. } = term else {
        panic!("not heteroscedastic")
    };
    assert!((k - 1.0).abs() < 3.0 * unc[0].1, "k {k} ± {}", unc[0].1);
    assert!((k - 1.0).abs() < tol, "k {k}");
}

/// 900 blocks of 100 Student-t samples (3 degrees of freedom) whose scale follows the
/// term, with `spikes` isolated 30σ spikes; (rate, temperatures).
fn t3_samples(k: f64, ref_c: f64, seed: u64, spikes: usize) -> (Vec<f64>, Vec<f64>) {
    let chi = ChiSquared::new(3.0_f64).expect("valid");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let temp: Vec<f64> = (0..900)
        .map(|b| 20.0 + 30.0 * (f64::from(b) / 150.0).sin())
        .collect();
    let mut rate = Vec::with_capacity(90_000);
    for t in &temp {
        let s = 1.0 + k * ((t - ref_c) / 30.0).powi(2);
        for j in 0..100 {
            let e: f64 = StandardNormal.sample(&mut rng);
            rate.push(0.01 * f64::from(j) + 0.015 * s * e / (chi.sample(&mut rng) / 3.0).sqrt());
        }
    }
    for i in 0..spikes {
        rate[7_919 * (i + 1) % 90_000] += 0.45;
    }
    (rate, temp)
}

/// t₃ noise is recognised as heavy-tailed; Gaussian noise with a few spikes is not.
#[test]
fn heavy_tails_are_recognised() {
    let (rate, temp) = t3_samples(0.0, 20.0, 1, 0);
    assert!(VarianceTest::from_samples(&rate, 100, temp)
        .expect("test")
        .heavy_tailed());
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut gauss: Vec<f64> = (0..90_000)
        .map(|_| {
            let e: f64 = StandardNormal.sample(&mut rng);
            0.015 * e
        })
        .collect();
    for i in 0..5 {
        gauss[7_919 * (i + 1)] += 0.45;
    }
    let temp = vec![20.0; 900];
    let t = VarianceTest::from_samples(&gauss, 100, temp).expect("test");
    assert!(!t.heavy_tailed());
}

/// On t₃ noise the ½-power scales find a noise scale the log-variances miss (k 0.02,
/// 20 data sets, each against its own permutations' 1 % quantile), and keep the
/// false-alarm rate near α without one (40 sets at 10 %).
#[test]
fn noise_scale_under_heavy_tails() {
    let flagged_at = |t: &VarianceTest, seed: u64, q: usize| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut null: Vec<f64> = (0..400).map(|_| t.replicate(&mut rng)).collect();
        null.sort_by(f64::total_cmp);
        t.dbic < null[q]
    };
    let (mut robust, mut variance) = (0, 0);
    for seed in 0..20u64 {
        let (rate, temp) = t3_samples(0.02, 35.0, 500 + seed, 0);
        let t = VarianceTest::from_samples(&rate, 100, temp.clone()).expect("test");
        robust += usize::from(flagged_at(&t, seed, 4));
        let raw: Vec<f64> = rate
            .chunks_exact(100)
            .map(|c| line_variance(c).expect("variance").ln())
            .collect();
        variance += usize::from(flagged_at(&test_of(raw, temp), seed, 4));
    }
    assert!(robust >= 15, "½-power scales: {robust} of 20 found");
    assert!(
        robust >= variance + 5,
        "{robust} vs log-variances {variance} of 20"
    );
    let clean = (0..40u64)
        .filter(|seed| {
            let (rate, temp) = t3_samples(0.0, 35.0, 700 + seed, 3);
            let t = VarianceTest::from_samples(&rate, 100, temp).expect("test");
            flagged_at(&t, *seed, 40)
        })
        .count();
    // Binomial(40, 0.1): mean 4, P(X > 10) < 0.3 %.
    assert!(clean <= 10, "{clean} of 40 clean sets flagged at 10 %");
}

/// A rate counted in whole angle increments coarser than its noise is recognised; a
/// continuous one, and one whose count the noise dithers, are not.
#[test]
fn output_quantum_is_read_from_the_rate() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let n = 30_000;
    let count = |rate: &[f64], q: f64| -> Vec<f64> {
        let (mut angle, mut counted) = (0.0f64, 0.0f64);
        rate.iter()
            .map(|r| {
                angle += r;
                let c = (angle / q).floor() * q;
                let out = c - counted;
                counted = c;
                out
            })
            .collect()
    };
    // 1 s samples: °/h·s is arcsec, so q is the count in arcsec.
    let continuous: Vec<f64> = (0..n)
        .map(|_| {
            let e: f64 = StandardNormal.sample(&mut rng);
            7.1 + 0.015 * e
        })
        .collect();
    let got = output_quantum(&count(&continuous, 0.1)).expect("quantised");
    assert!((got / 0.1 - 1.0).abs() < 1e-3, "{got}");
    assert_eq!(output_quantum(&continuous), None);
    assert_eq!(output_quantum(&count(&continuous, 0.02)), None, "dithered");
}

/// D grows with k and is zero without the term.
#[test]
fn detectability_grows_with_k() {
    let temp: Vec<f64> = (0..40_000).map(|i| 10.0 + f64::from(i) / 1000.0).collect();
    assert_eq!(heteroscedastic_detectability(&temp, 0.0, 20.0), 0.0);
    let d1 = heteroscedastic_detectability(&temp, 0.01, 20.0);
    let d2 = heteroscedastic_detectability(&temp, 0.02, 20.0);
    assert!(d1 > 0.0 && (d2 / d1 - 2.0).abs() < 0.05, "{d1} {d2}");
}

/// The level in time that the noise-scale test is put against takes the shape of the change:
/// a step's time and an episode's ends within a few blocks, a smooth drift as a drift.
#[test]
fn a_level_in_time_finds_its_shape() {
    let n = 300;
    let time_s: Vec<f64> = (0..n).map(|b| 130.0 + 100.0 * b as f64).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let noise: Vec<f64> = (0..n)
        .map(|_| 0.15 * Distribution::<f64>::sample(&StandardNormal, &mut rng))
        .collect();
    let with = |f: &dyn Fn(usize) -> f64| -> Vec<f64> {
        centred(
            &noise
                .iter()
                .enumerate()
                .map(|(b, e)| e + f(b))
                .collect::<Vec<_>>(),
        )
    };
    let step = with(&|b| if b >= 137 { 0.6 } else { 0.0 });
    match LevelInTime::best(&step, &time_s) {
        Some(LevelInTime::Step { at }) => assert!(at.abs_diff(137) <= 4, "{at}"),
        other => panic!("{other:?}"),
    }
    let episode = with(&|b| if (90..170).contains(&b) { -0.6 } else { 0.0 });
    match LevelInTime::best(&episode, &time_s) {
        Some(LevelInTime::Episode { from, to }) => {
            assert!(
                from.abs_diff(90) <= 4 && to.abs_diff(170) <= 4,
                "{from}..{to}"
            );
        }
        other => panic!("{other:?}"),
    }
    let drift = with(&|b| 1.2 * (b as f64 / n as f64 - 0.5).powi(2));
    assert_eq!(LevelInTime::best(&drift, &time_s), Some(LevelInTime::Drift));
}

/// 600 blocks of 100 samples of a count at block temperatures `temp(block)` (within 0…50 °C,
/// the bias moving two counts over them), white noise of σ 0.25 counts times
/// `scale(block, temperature)` (under half a count over the record, or it is not read as an
/// undithered count); (rate, temperatures, block times).
fn counted_over(
    temp: &dyn Fn(usize) -> f64,
    scale: &dyn Fn(usize, f64) -> f64,
    seed: u64,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    counted(600, 0.25, temp, scale, seed)
}

/// Which the noise level of an undithered count follows, `several_cycles` or not.
fn follows(
    temp: &dyn Fn(usize) -> f64,
    scale: &dyn Fn(usize, f64) -> f64,
    several_cycles: bool,
    seed: u64,
) -> Option<LevelInTime> {
    let (rate, temp, time_s) = counted_over(temp, scale, seed);
    let t = VarianceTest::from_samples(&rate, 100, temp).expect("test");
    assert!(t.counts());
    t.in_time_not_temperature(&time_s, several_cycles)
        .map(|(_, level)| level)
}

/// On an undithered count, a white-noise level that changes in time is put down to time, not
/// temperature, over one temperature ramp (time and temperature together) and over two
/// cycles: the count's own part, which changes with the noise by how much depending on where
/// the rate falls between counts (on temperature), changes with it. A noise that grows with
/// temperature keeps its name on both.
#[test]
fn a_noise_level_in_time_on_counts_is_not_a_noise_scale() {
    let ramp = |b: usize| 50.0 * b as f64 / 600.0;
    let cycles = |b: usize| 25.0 + 25.0 * (std::f64::consts::TAU * b as f64 / 300.0).sin();
    let step = |b: usize, _: f64| if b >= 250 { 2.0 } else { 1.0 };
    let drift = |b: usize, _: f64| 1.0 + 0.8 * b as f64 / 600.0;
    let with_temp = |_: usize, t: f64| 1.0 + 0.5 * ((t - 10.0) / 30.0).powi(2);
    match follows(&ramp, &step, false, 5) {
        Some(LevelInTime::Step { at }) => assert!(at.abs_diff(250) <= 6, "step at {at}"),
        other => panic!("{other:?}"),
    }
    assert_eq!(follows(&cycles, &drift, true, 7), Some(LevelInTime::Drift));
    assert_eq!(follows(&ramp, &with_temp, false, 6), None);
    assert_eq!(follows(&cycles, &with_temp, true, 8), None);
}
