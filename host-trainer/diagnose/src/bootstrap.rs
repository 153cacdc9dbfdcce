//! Significance by a parametric bootstrap of the fitted gyro noise model: the null
//! distributions of the best candidate over all families, each family's ΔBIC on its own
//! tail (the look-elsewhere effect included), of each family alone and of the
//! generic-structure test, and each replicate's ranks in the two tests, from which the
//! verdict's false-alarm probability (that of the smaller of the two tests' p-values)
//! follows.

use rayon::prelude::*;

use super::candidates::Family;
use super::linalg::dot;
use super::noise::replicates::{replicate_rng, simulate_block_means_levelled};
use super::prepare::Prepared;
use super::scan::Scanned;
use super::score::delta_bic;
use super::variance::VarianceTest;
use super::Options;
use rand_chacha::ChaCha8Rng;
use rlg_simulate::noise::NoiseParams;

/// The tail probability at which each family's own null is read for its offset (see
/// [`bootstrap`]): a point in the tail, not the median, because the families' nulls differ
/// in spread as well as in place and the threshold is a point in the tail; not further out,
/// where 400 replicates place a quantile only to a few replicates.
pub(super) const FAMILY_TAIL: f64 = 0.05;

/// The null distributions from a parametric bootstrap of the fitted gyro noise model
/// (replicates whitened exactly as the data are and run through the same scan): of the best
/// candidate over all families and grid points (the look-elsewhere effect included), and of
/// the generic-structure ΔBIC; their thresholds are in [`Nulls::threshold`].
///
/// The best candidate is the lowest of each family's best ΔBIC less its offset, the family's
/// own null at tail probability [`FAMILY_TAIL`]: on the raw ΔBIC the families that scan
/// widest (a period over hundreds of frequencies, the other node's lags) set the threshold
/// for all, and a one-parameter drift or a loop that its own family alone finds at the
/// bootstrap's floor is `consistent`. Offsets put the families' tails side by side, so
/// each is asked for about the same tail probability under its own null; the replicates go
/// through the same offsets, so the test stays calibrated on the noise model. Where the
/// white level changes in time, `white_level` scales each block's white variance.
pub(super) fn bootstrap(
    scanned: &Scanned<'_>,
    gyro: &NoiseParams,
    white_level: Option<&[f64]>,
    var: Option<&VarianceTest>,
    prep: &Prepared,
    opts: &Options,
) -> Nulls {
    let (ar, s, points) = (scanned.whitener, scanned.scan, scanned.points);
    // The replicates' series first (each with its generator, which the variance test's
    // replicate continues), then whitened together (batched triangular solves).
    let sims: Vec<(Vec<f64>, ChaCha8Rng)> = (0..opts.bootstrap.max(1))
        .into_par_iter()
        .map(|k| {
            let mut rng = replicate_rng(opts.seed, k as u64);
            let x = simulate_block_means_levelled(
                gyro,
                white_level,
                prep.nb(),
                prep.block as f64 * prep.dt_s,
                &mut rng,
                opts.seed.wrapping_add(k as u64 + 1),
            );
            (x, rng)
        })
        .collect();
    let xs: Vec<&[f64]> = sims.iter().map(|(x, _)| x.as_slice()).collect();
    let whitened = ar.whiten_many(&xs);
    let reps: Vec<(Vec<f64>, f64)> = sims
        .into_par_iter()
        .zip(whitened)
        .map(|((_, mut rng), w)| {
            let e = s.basis.residual(&w);
            let rss0 = dot(&e, &e);
            // The best ΔBIC of each family (indexed as `Family::ALL`).
            let mut best = vec![f64::INFINITY; Family::ALL.len()];
            // The variance test's replicate: independent of the block means (it sees the
            // samples about each block's line, they see each block's mean).
            let var_d = var.map(|v| v.replicate(&mut rng));
            for ((cp, fit), p) in s.cperp.iter().zip(&s.fits).zip(points) {
                let d = match (p.family, var_d) {
                    (Family::Heteroscedastic, Some(d)) => d,
                    _ => delta_bic(s.n, rss0, fit.drss(cp, &e), p.n_params()),
                };
                let b = &mut best[p.family.index()];
                *b = b.min(d);
            }
            let (_, g) = s.gen.best(&e, s.n, rss0);
            (best, g)
        })
        .collect();
    Nulls::of_families(&reps)
}

/// One of the two tests whose smaller p-value decides the verdict.
#[derive(Clone, Copy, Debug)]
pub(super) enum Test {
    /// The best candidate over every family and grid point.
    Best,
    /// The generic structure test.
    Structure,
}

/// The bootstrap's null distributions.
pub(super) struct Nulls {
    /// Best candidate over every family and grid point (each family's ΔBIC less its
    /// offset): the test's.
    pub(super) best: NullDist,
    /// Best ΔBIC within each family (as `Family::ALL`): what the test would be if that family
    /// alone were tested, its own scan the only look-elsewhere: its offset is read from it.
    pub(super) family: Vec<NullDist>,
    /// Each family's offset (as `Family::ALL`): the best-candidate test compares each
    /// family's ΔBIC less its offset (zero in `Nulls::new`).
    pub(super) offset: Vec<f64>,
    /// Generic structure ΔBIC.
    pub(super) structure: NullDist,
    /// Each replicate's rank among the replicates in the two tests (best candidate, generic
    /// structure; 1 = the most extreme).
    ranks: Vec<(u32, u32)>,
}

impl Nulls {
    /// The nulls of the two tests from each replicate's pair of statistics (in the same
    /// order); the per-family nulls are left empty.
    pub(super) fn new(best: Vec<f64>, structure: Vec<f64>) -> Self {
        let (b, s) = (
            NullDist::new(best.clone()),
            NullDist::new(structure.clone()),
        );
        let ranks = best
            .iter()
            .zip(&structure)
            .map(|(&x, &y)| (b.rank(x), s.rank(y)))
            .collect();
        Self {
            best: b,
            family: Vec::new(),
            offset: vec![0.0; Family::ALL.len()],
            structure: s,
            ranks,
        }
    }

    /// The nulls from each replicate's best ΔBIC by family (as `Family::ALL`) and its
    /// generic-structure ΔBIC: the candidate test's statistic is the lowest of the families'
    /// ΔBIC less their offsets.
    fn of_families(reps: &[(Vec<f64>, f64)]) -> Self {
        let families = reps.first().map_or(0, |r| r.0.len());
        let family: Vec<NullDist> = (0..families)
            .map(|f| NullDist::new(reps.iter().map(|r| r.0[f]).collect()))
            .collect();
        let offset: Vec<f64> = family.iter().map(NullDist::offset).collect();
        let overall = |r: &[f64]| {
            r.iter()
                .zip(&offset)
                .map(|(d, c)| d - c)
                .fold(f64::INFINITY, f64::min)
        };
        let mut nulls = Self::new(
            reps.iter().map(|r| overall(&r.0)).collect(),
            reps.iter().map(|r| r.1).collect(),
        );
        nulls.family = family;
        nulls.offset = offset;
        nulls
    }

    /// The verdict is not `consistent` when either test is significant, so its false-alarm
    /// probability is that of the smaller of their two p-values, up to twice each test's
    /// (by how much depends on how alike the two tests are on the record's noise; the same
    /// replicates measure it, a min-p adjustment as in Westfall & Young 1993). This maps the
    /// p-value `p` of one test to that scale, given the record's p-value `p_other` in the
    /// other: (1 + the replicates whose smaller p-value is below `p`, or equal to it with
    /// the larger no larger) / (B + 1), the record counted among the replicates as in
    /// [`NullDist::p_value`].
    ///
    /// The replicates' p-values are their ranks among record and replicates: a replicate's
    /// rank among the replicates alone is one less where the record is more extreme. Ranks
    /// among the replicates alone would make the adjusted p-value one step of 1/(B + 1) too
    /// large (in the record's own test the replicate just past it would count) and count
    /// every tie between the two tests, which halves the false alarms under an exact null
    /// (test `either_p_is_exact_under_an_exchangeable_null`). The structure test enters
    /// as it is in the replicates (without the second null under rate random walk that can
    /// raise a record's p-value); a raised `p` is placed among the ranks as it is.
    pub(super) fn either_p(&self, p: f64, test: Test, p_other: f64) -> f64 {
        let b1 = (self.ranks.len() + 1) as f64;
        // A p-value of either test is (1 + k)/(B + 1), its rank among record and
        // replicates, up to rounding, which `TOL` absorbs.
        const TOL: f64 = 1e-6;
        let (r, r_o) = (p * b1, p_other * b1);
        let key = (r, r.max(r_o));
        let k = self
            .ranks
            .iter()
            .filter(|&&(rb, rs)| {
                let (own, other) = match test {
                    Test::Best => (f64::from(rb), f64::from(rs)),
                    Test::Structure => (f64::from(rs), f64::from(rb)),
                };
                let own = if own < r - TOL { own } else { own + 1.0 };
                let other = if other < r_o - TOL {
                    other
                } else {
                    other + 1.0
                };
                let (lo, hi) = (own.min(other), own.max(other));
                lo < key.0 - TOL || (lo <= key.0 + TOL && hi <= key.1 + TOL)
            })
            .count();
        ((1 + k) as f64 / b1).max(p)
    }

    /// The ΔBIC threshold of a test at false-alarm probability `alpha` for the two tests
    /// together, given the record's p-value `p_other` in the other test: a record's ΔBIC
    /// below it is exactly a p-value whose `either_p` is at most `alpha` (negative infinity
    /// when no rank gets there).
    pub(super) fn threshold(&self, alpha: f64, test: Test, p_other: f64) -> f64 {
        let dist = match test {
            Test::Best => &self.best,
            Test::Structure => &self.structure,
        };
        let b1 = (dist.0.len() + 1) as f64;
        // `either_p` grows with the rank: the largest rank R with `either_p(R/(B + 1))` ≤ α.
        let r = (1..=dist.0.len())
            .collect::<Vec<_>>()
            .partition_point(|&r| self.either_p(r as f64 / b1, test, p_other) <= alpha);
        // A p-value (1 + k)/(B + 1) ≤ R/(B + 1) is k ≤ R − 1 replicates at or below the
        // ΔBIC: a ΔBIC below the R-th smallest replicate.
        if r == 0 {
            f64::NEG_INFINITY
        } else {
            dist.0[r - 1]
        }
    }
}

/// A bootstrap null distribution of a ΔBIC (more negative = stronger evidence).
pub(super) struct NullDist(pub(super) Vec<f64>);

impl NullDist {
    pub(super) fn new(mut v: Vec<f64>) -> Self {
        v.sort_by(f64::total_cmp);
        Self(v)
    }

    /// A family's offset on the best-candidate test's common scale: its own null's value at
    /// tail probability [`FAMILY_TAIL`] (zero for a family the scan did not try).
    fn offset(&self) -> f64 {
        let r = ((FAMILY_TAIL * (self.0.len() + 1) as f64).round() as usize)
            .clamp(1, self.0.len().max(1));
        self.0
            .get(r - 1)
            .copied()
            .filter(|v| v.is_finite())
            .unwrap_or(0.0)
    }

    /// A replicate's rank among the replicates (1 = the most extreme; itself counted).
    fn rank(&self, x: f64) -> u32 {
        u32::try_from(self.0.partition_point(|v| *v <= x)).unwrap_or(u32::MAX)
    }

    /// Bootstrap p-value of an observed ΔBIC: (1 + #replicates at least as extreme)/(B + 1).
    pub(super) fn p_value(&self, x: f64) -> f64 {
        let k = self.0.partition_point(|v| *v <= x);
        (1 + k) as f64 / (self.0.len() + 1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::{NullDist, Nulls, Test};
    use crate::Family;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn nulls(pairs: &[(f64, f64)]) -> Nulls {
        Nulls::new(
            pairs.iter().map(|p| p.0).collect(),
            pairs.iter().map(|p| p.1).collect(),
        )
    }

    /// Two tests that are extreme on the same replicates need no adjustment; two that are
    /// extreme on different replicates double each p-value and halve each test's level.
    #[test]
    fn either_test_adjustment_follows_the_replicates() {
        let n = 400;
        // The same ranks in both tests.
        let same: Vec<(f64, f64)> = (1..=n).map(|k| (-f64::from(k), -f64::from(k))).collect();
        // Opposite ranks: the replicate most extreme in one is least extreme in the other.
        let opposite: Vec<(f64, f64)> = (1..=n)
            .map(|k| (-f64::from(k), -f64::from(n + 1 - k)))
            .collect();
        let (a, b) = (nulls(&same), nulls(&opposite));
        let r = 1.0 / 401.0;
        for t in [Test::Best, Test::Structure] {
            for p in [0.01, 0.02, 0.05, 0.1] {
                let p = (p * 401.0_f64).round() * r;
                let (pa, pb) = (a.either_p(p, t, 1.0), b.either_p(p, t, 1.0));
                assert!((pa - p).abs() <= 1.5 * r, "same, {t:?}: {p} -> {pa}");
                assert!(
                    (pb - 2.0 * p).abs() <= 1.5 * r,
                    "opposite, {t:?}: {p} -> {pb}"
                );
            }
            // The threshold's p-value: α for the same ranks, α/2 for opposite ones.
            for alpha in [0.01, 0.02, 0.05, 0.1] {
                let pa = a.best.p_value(a.threshold(alpha, t, 1.0) - 0.5);
                let pb = b.best.p_value(b.threshold(alpha, t, 1.0) - 0.5);
                assert!(
                    (pa - alpha).abs() <= 1.5 * r,
                    "same, {t:?}: {alpha} -> {pa}"
                );
                assert!(
                    (pb - alpha / 2.0).abs() <= 1.5 * r,
                    "opposite, {t:?}: {alpha} -> {pb}"
                );
            }
        }
        // The adjusted p-value is never below the test's own.
        for p in [r, 0.3, 1.0] {
            assert!(
                a.either_p(p, Test::Best, 1.0) >= p && b.either_p(p, Test::Structure, 1.0) >= p
            );
        }
    }

    /// With the record exchangeable with its replicates (all drawn alike), the share of
    /// records whose smaller adjusted p-value is at most α is α, for independent and for
    /// correlated tests; and a ΔBIC below a test's threshold is exactly an adjusted p-value
    /// at most α. Ranks among the replicates alone (the replicate just past the record
    /// counted in its own test, ties between the tests counted) give about half the
    /// expected share here.
    #[test]
    fn either_p_is_exact_under_an_exchangeable_null() {
        let (trials, b) = (10_000, 400);
        let alphas = [0.01, 0.02, 0.05, 0.1];
        for rho in [0.0, 0.7] {
            let mut rng = ChaCha8Rng::seed_from_u64(20_261_129);
            let mut draw = || {
                let z1: f64 = StandardNormal.sample(&mut rng);
                let z2: f64 = StandardNormal.sample(&mut rng);
                (z1, rho * z1 + (1.0 - rho * rho).sqrt() * z2)
            };
            let mut flagged = [0usize; 4];
            for trial in 0..trials {
                let (x, y) = draw();
                let reps: Vec<(f64, f64)> = (0..b).map(|_| draw()).collect();
                let n = nulls(&reps);
                let (pb, ps) = (n.best.p_value(x), n.structure.p_value(y));
                let p = n
                    .either_p(pb, Test::Best, ps)
                    .min(n.either_p(ps, Test::Structure, pb));
                for (k, &a) in alphas.iter().enumerate() {
                    flagged[k] += usize::from(p <= a);
                    // The thresholds agree with the p-value (checked on some trials: a
                    // threshold is a search over ranks).
                    if trial % 50 == 0 {
                        let sig = x < n.threshold(a, Test::Best, ps)
                            || y < n.threshold(a, Test::Structure, pb);
                        assert_eq!(sig, p <= a, "rho {rho} alpha {a} p {p}");
                    }
                }
            }
            for (k, &a) in alphas.iter().enumerate() {
                // 3.5 binomial sd: 35 of the 100 expected at 1 %, 105 of 1 000 at 10 %.
                let expect = a * trials as f64;
                let sd = (expect * (1.0 - a)).sqrt();
                let got = flagged[k] as f64;
                assert!(
                    (got - expect).abs() <= 3.5 * sd,
                    "rho {rho}: {got} of {trials} at alpha {a} (expected {expect})"
                );
            }
        }
    }

    /// A family of one parameter beside one that scans three hundred points: on the raw
    /// ΔBIC the wide scan takes nearly all of the test's false alarms and the narrow family
    /// needs far more evidence than it would alone; on their tails the two share them, and
    /// the test's level is kept.
    #[test]
    fn families_on_their_tails_share_the_false_alarms() {
        let (b, trials, alpha) = (2_000, 4_000, 0.05);
        let mut rng = ChaCha8Rng::seed_from_u64(20_261_204);
        // A family's best ΔBIC over `k` independent points of one parameter each
        // (−χ²₁ + ln n, n = 1 000 means).
        let mut best_of = |k: usize| {
            (0..k)
                .map(|_| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    1000.0_f64.ln() - z * z
                })
                .fold(f64::INFINITY, f64::min)
        };
        let mut draw = || (vec![best_of(1), best_of(300)], 0.0);
        let reps: Vec<(Vec<f64>, f64)> = (0..b).map(|_| draw()).collect();
        let (tails, raw) = (
            Nulls::of_families(&reps),
            Nulls::new(
                reps.iter().map(|r| r.0[0].min(r.0[1])).collect(),
                vec![0.0; b],
            ),
        );
        // The record's false alarms by family at the best-candidate test's level α alone.
        let (mut on_tails, mut on_raw) = ([0_u32; 2], [0_u32; 2]);
        let thr_tails = tails.best.0[(alpha * (b + 1) as f64) as usize - 1];
        let thr_raw = raw.best.0[(alpha * (b + 1) as f64) as usize - 1];
        for _ in 0..trials {
            let (x, _) = draw();
            let scaled: Vec<f64> = x.iter().zip(&tails.offset).map(|(d, c)| d - c).collect();
            let f = usize::from(scaled[1] < scaled[0]);
            on_tails[f] += u32::from(scaled[f] < thr_tails);
            let f = usize::from(x[1] < x[0]);
            on_raw[f] += u32::from(x[f] < thr_raw);
        }
        let level = |c: [u32; 2]| f64::from(c[0] + c[1]) / f64::from(trials);
        // α = 5 % of 4 000 trials: 200 ± 14; the 2 000 replicates place the threshold to
        // about ± 0.5 % in level.
        for c in [on_tails, on_raw] {
            assert!((level(c) - alpha).abs() < 0.02, "level {}", level(c));
        }
        assert!(
            on_raw[0] * 10 < on_raw[1],
            "raw: one-parameter family {} of {} false alarms",
            on_raw[0],
            on_raw[0] + on_raw[1]
        );
        assert!(
            on_tails[0] * 2 > on_tails[1] && on_tails[1] * 2 > on_tails[0],
            "on tails: {on_tails:?}"
        );
    }

    /// The per-family nulls are indexed by `Family::index`, which must follow `Family::ALL`.
    #[test]
    fn family_index_follows_all() {
        for (i, f) in Family::ALL.into_iter().enumerate() {
            assert_eq!(f.index(), i, "{}", f.name());
        }
    }

    /// A p-value is (1 + the replicates at least as extreme)/(B + 1).
    #[test]
    fn p_value_counts_the_record_among_the_replicates() {
        // Replicates −1, −2, …, −400 (ΔBIC; lower = more extreme).
        let d = NullDist::new((1..=400).map(|k| -f64::from(k)).collect());
        assert!((d.p_value(-396.5) - 5.0 / 401.0).abs() < 1e-12);
        assert!((d.p_value(-1000.0) - 1.0 / 401.0).abs() < 1e-12);
        assert!((d.p_value(0.0) - 1.0).abs() < 1e-12);
        assert_eq!(d.rank(-400.0), 1);
        assert_eq!(d.rank(-1.0), 400);
    }
}
