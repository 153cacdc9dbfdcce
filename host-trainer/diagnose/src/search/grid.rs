//! The candidate grid of one pass: every family the model lacks, each point's block columns,
//! and the noise-scale test, which scans the samples' variance instead of the means.

use std::sync::Arc;

use rayon::prelude::*;

use super::cache::ColumnCache;
use crate::baseline::Baseline;
use crate::candidates::Family;
use crate::noise::whiten::Whitener;
use crate::prepare::{Prepared, BLOCK_S, MAX_BLOCKS};
use crate::scan::{scan, Generic, Point, Scan};
use crate::variance::{output_quantum, VarianceTest, MIN_COUNT_SIGMA};
use crate::DiagnoseError;

/// The points a pass scans.
pub(super) struct Grid {
    /// The families the model lacks, in [`Family::ALL`]'s order.
    pub(super) families: Vec<Family>,
    /// Every point of their grids; the noise-scale test's, when it runs, last.
    pub(super) points: Vec<Point>,
    /// The noise-scale test, when the model lacks the term and the record allows it.
    pub(super) var: Option<VarianceTest>,
    /// Its point among `points`.
    var_point: Option<usize>,
}

impl Grid {
    /// The grid of every family `base`'s model lacks, its columns from `cache` where kept.
    pub(super) fn build(base: &Baseline<'_>, cache: &ColumnCache) -> Result<Self, DiagnoseError> {
        let families: Vec<Family> = Family::ALL
            .into_iter()
            .filter(|f| !base.model.has(f.mechanism()))
            .collect();
        let specs: Vec<(Family, Vec<f64>)> = families
            .iter()
            .flat_map(|f| f.grid(base.prep).into_iter().map(move |nl| (*f, nl)))
            .collect();
        let mut points: Vec<Point> = specs
            .into_par_iter()
            .map(|(family, nl)| {
                Ok(Point {
                    family,
                    cols_b: cache
                        .get_or_build(family, &nl, || base.candidate_blocks(family, &nl))?,
                    nl,
                })
            })
            .collect::<Result<_, DiagnoseError>>()?;
        // The noise-scale family: one point with no mean column, its ΔBIC from the variance
        // test.
        let var = families
            .contains(&Family::Heteroscedastic)
            .then(|| VarianceTest::new(base.prep))
            .flatten();
        let var_point = var.as_ref().map(|_| {
            points.push(Point {
                family: Family::Heteroscedastic,
                nl: Vec::new(),
                cols_b: Arc::default(),
            });
            points.len() - 1
        });
        Ok(Self {
            families,
            points,
            var,
            var_point,
        })
    }

    /// What the evidence says of how the record was read: longer blocks on a long record,
    /// and how the noise-scale test took the samples.
    pub(super) fn reading_notes(&self, prep: &Prepared) -> Vec<String> {
        let mut notes = Vec::new();
        let block_s = prep.block as f64 * prep.dt_s;
        // (A record of burst means has one sample per block, however long the blocks.)
        if prep.block > 1 && block_s < BLOCK_S / 1.5 {
            notes.push(format!(
                "the record is {:.1} h long: it is analysed as {} means of {block_s:.0} s instead \
                 of 100 s means (at least {} blocks are needed)",
                prep.nb() as f64 * block_s / 3600.0,
                prep.nb(),
                crate::prepare::MIN_BLOCKS
            ));
        }
        if prep.block > 1 && block_s > BLOCK_S * 1.5 {
            notes.push(format!(
                "the record is {:.1} days long: it is analysed as {} means of {block_s:.0} s (at \
                 most {} blocks) instead of 100 s means, and periodic terms are searched down to \
                 periods of {:.0} s",
                prep.nb() as f64 * block_s / 86_400.0,
                prep.nb(),
                MAX_BLOCKS,
                4.0 * block_s
            ));
        }
        if let Some(q) = output_quantum(&prep.rate_dph) {
            notes.extend(self.count_note(q, prep.dt_s));
        }
        if let Some(d) = self
            .var
            .as_ref()
            .map(VarianceTest::detrend_degree)
            .filter(|d| *d > 1)
        {
            notes.push(format!(
                "the rate curves within the 100 s blocks by more than its 1 s noise (a large \
                 temperature coefficient where the ramps bend): the noise-scale test takes each \
                 block's variance about a polynomial of degree {d}, not its straight line"
            ));
        }
        if self.var.as_ref().is_some_and(VarianceTest::heavy_tailed) {
            notes.push(
                "the white noise is heavy-tailed (samples beyond 4 RMS of their block more than \
                 ten times as often as Gaussian noise): the noise-scale test compares the blocks' \
                 ½-power means of their deviations, not their variances"
                    .to_string(),
            );
        }
        notes
    }

    /// The note on a rate that is an undithered count of `q` °/h per sample: how the
    /// noise-scale test dealt with it, or why it did not run.
    fn count_note(&self, q: f64, dt_s: f64) -> Option<String> {
        let counts = format!(
            "the rate is an undithered count ({q:.4} °/h per sample, {:.4}″ counts)",
            q * dt_s
        );
        if let Some(v) = self.var.as_ref() {
            let summed = match v.summed() {
                1 => String::new(),
                k => format!(
                    " (on sums of {k} samples: the noise is a small fraction of a count, \
                     and a sum's noise grows with k while its count error does not)"
                ),
            };
            Some(format!(
                "{counts}: the noise-scale test takes out the count's own variance, which \
                 follows where each block's mean rate falls between counts{summed}"
            ))
        } else if self.families.contains(&Family::Heteroscedastic) {
            Some(format!(
                "{counts} whose noise is too small a part of a count even summed over a few \
                 samples (under {MIN_COUNT_SIGMA} counts, or a block whose sums are all \
                 equal): the noise-scale test is not run (what remains of the variance \
                 follows where the rate falls between counts)"
            ))
        } else {
            None
        }
    }

    /// The scan of every point in `whitener`'s metric; the points keep their family and
    /// parameters only (the scan holds their whitened columns: on a month, the raw ones
    /// are another 180 MB), and the noise-scale point gets the variance test's ΔBIC.
    pub(super) fn scan(
        &mut self,
        whitener: &Whitener,
        base: &Baseline<'_>,
        generic: &Generic,
    ) -> Scan {
        let mut s = scan(
            whitener,
            &base.cols_b,
            &base.prep.y_b,
            &self.points,
            generic,
        );
        for p in &mut self.points {
            p.cols_b = Arc::default();
        }
        if let (Some(i), Some(v)) = (self.var_point, self.var.as_ref()) {
            s.dbic[i] = v.dbic;
        }
        s
    }
}
