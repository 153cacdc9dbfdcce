//! The pass's significance scale: the bootstrap's nulls, the record's p-value in each of the
//! two tests alone, and each test's threshold at the level that gives the two together
//! false-alarm probability α.

use super::noise_model::FittedNoise;
use crate::bootstrap::{bootstrap, Nulls, Test};
use crate::candidates::Family;
use crate::prepare::Prepared;
use crate::scan::Scanned;
use crate::variance::VarianceTest;
use crate::Options;

/// The thresholds and p-values of one pass.
pub(super) struct Significance {
    /// The bootstrap's null distributions.
    pub(super) nulls: Nulls,
    /// The record's p-value in the generic structure test alone.
    pub(super) structure_alone: f64,
    /// The record's p-value in the best-candidate test alone.
    pub(super) best_alone: f64,
    /// The ΔBIC threshold of the best-candidate test (one for every family).
    best_threshold: f64,
    /// The ΔBIC threshold of the generic structure test.
    pub(super) structure_threshold: f64,
    /// With a rate ramp preferred to rate random walk, every p-value rests on that choice:
    /// none is below this.
    floor: Option<f64>,
}

impl Significance {
    /// The bootstrap of `noise` through the scan of the record (`scanned`, with the
    /// noise-scale test `var` where it runs), and the thresholds at `opts.alpha`.
    pub(super) fn new(
        scanned: &Scanned<'_>,
        noise: &FittedNoise,
        var: Option<&VarianceTest>,
        prep: &Prepared,
        opts: &Options,
    ) -> Self {
        let s = scanned.scan;
        let nulls = bootstrap(
            scanned,
            &noise.gyro,
            noise.white_level.as_deref(),
            var,
            prep,
            opts,
        );
        // The record's p-value in each test alone: the other test's breaks ties between the
        // two (see `Nulls::either_p`).
        let structure_alone = nulls.structure.p_value(s.gen_dbic);
        let best_alone = nulls.best.p_value(
            s.dbic
                .iter()
                .zip(scanned.points)
                .map(|(d, p)| d - nulls.offset[p.family.index()])
                .fold(f64::INFINITY, f64::min),
        );
        // Each test at the level that gives the two together false-alarm probability α.
        let (best_threshold, structure_threshold) = (
            nulls.threshold(opts.alpha, Test::Best, structure_alone),
            nulls.threshold(opts.alpha, Test::Structure, best_alone),
        );
        Self {
            nulls,
            structure_alone,
            best_alone,
            best_threshold,
            structure_threshold,
            floor: noise.ramp.as_ref().map(|r| r.p_under_rrw),
        }
    }

    /// The ΔBIC threshold of family `f`: the best-candidate test's, on the family's scale.
    pub(super) fn threshold(&self, f: Family) -> f64 {
        self.best_threshold + self.nulls.offset[f.index()]
    }

    /// A family's ΔBIC on the best-candidate test's common scale (lower = more significant).
    fn scaled(&self, f: Family, dbic: f64) -> f64 {
        dbic - self.nulls.offset[f.index()]
    }

    /// `p` raised to the ramp's p-value where a ramp was preferred to rate random walk.
    pub(super) fn floor(&self, p: f64) -> f64 {
        self.floor.map_or(p, |q| p.max(q))
    }

    /// A candidate's p-value on the verdict's scale: its ΔBIC `dbic` against the best
    /// candidate's null, adjusted for either test, at least its p-value under the record's
    /// slow noise `p_slow` where that was asked.
    pub(super) fn candidate_p(&self, f: Family, dbic: f64, p_slow: Option<f64>) -> f64 {
        self.floor(
            self.nulls
                .either_p(
                    self.nulls.best.p_value(self.scaled(f, dbic)),
                    Test::Best,
                    self.structure_alone,
                )
                .max(p_slow.unwrap_or(0.0)),
        )
    }

    /// A candidate's p-value had its family been the only one tested.
    pub(super) fn alone_p(&self, f: Family, dbic: f64) -> f64 {
        self.nulls.family[f.index()].p_value(dbic)
    }

    /// A p-value of the generic structure test on the verdict's scale.
    pub(super) fn structure_p(&self, p: f64) -> f64 {
        self.nulls.either_p(p, Test::Structure, self.best_alone)
    }
}
