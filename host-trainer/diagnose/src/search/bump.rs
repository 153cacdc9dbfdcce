//! A bump of the bias at one temperature: a shift while the temperature is between two
//! levels, on heating and cooling alike, and none outside them. No term of the library has
//! that shape, and the two that are stationary in temperature take it otherwise: the
//! backscatter ripple fits the bump with one of its lobes (and puts lobes where there are
//! none), a mode hop fits it with a step at its near edge.

use crate::candidates::Family;
use crate::prepare::Prepared;
use crate::scan::{temp_windows, Scanned, BUMP_TEMP_WIDTHS, TEMP_WINDOW_PARAMS};
use crate::BumpEvidence;

use super::step::{instead, Against, Placements};

/// The windows in temperature a bump is tried at: their edges, °C, and their whitened
/// columns.
pub(super) struct BumpScan {
    edges_c: Vec<(f64, f64)>,
    placements: Placements,
}

impl BumpScan {
    fn new(scanned: &Scanned<'_>, prep: &Prepared) -> Option<Self> {
        let (edges_c, raw): (Vec<(f64, f64)>, Vec<Vec<f64>>) =
            temp_windows(prep, BUMP_TEMP_WIDTHS).into_iter().unzip();
        if raw.is_empty() {
            return None;
        }
        Some(Self {
            edges_c,
            placements: Placements::new(scanned.whitener, scanned.scan, &raw, TEMP_WINDOW_PARAMS),
        })
    }
}

/// A bump preferred to a family.
#[derive(Debug, Clone, Copy)]
pub(super) struct Bump {
    lo_c: f64,
    hi_c: f64,
    height_dph: f64,
    delta_bic: f64,
    p_family: f64,
    p_bump: f64,
}

/// Salt of the bump test's replicates (another stream than the step test's).
const BUMP_SEED: u64 = 0xb0b5;

/// `Some(bump)` when the family of the scan's point `i` is a backscatter ripple or a mode
/// hop and the record is better explained by a bump at one temperature than by that family
/// ([`instead`], the bump's edges searched over the windows in temperature of the generic
/// structure test and wider ones, [`BUMP_TEMP_WIDTHS`]). The windows are made once per pass,
/// in `cached`.
pub(super) fn bump_instead(
    on: &Against<'_>,
    i: usize,
    cached: &mut Option<Option<BumpScan>>,
) -> Option<Bump> {
    if !matches!(
        on.scanned.points[i].family,
        Family::Backscatter | Family::ModeHop
    ) {
        return None;
    }
    let sc = cached
        .get_or_insert_with(|| BumpScan::new(on.scanned, on.prep))
        .as_ref()?;
    let p = instead(on, i, &sc.placements, BUMP_SEED)?;
    let (lo_c, hi_c) = sc.edges_c[p.index];
    Some(Bump {
        lo_c,
        hi_c,
        height_dph: p.height_dph,
        delta_bic: p.delta_bic,
        p_family: p.p_family,
        p_bump: p.p_shape,
    })
}

impl Bump {
    /// The note and the evidence of this bump, preferred to family `f` whose best ΔBIC is
    /// `family_dbic`.
    pub(super) fn evidence(&self, f: Family, family_dbic: f64) -> (String, BumpEvidence) {
        let name = f.name();
        let note = format!(
            "a bump of {:.2e} °/h between {:.1} and {:.1} °C (a raised cosine, on heating and \
             cooling alike; ΔBIC {:.1}) explains it better than {name} (ΔBIC {:.1}): \
             under {name} and the fitted noise a bump fits this much better in a share \
             {:.3} of bootstrap replicates, under the bump {name} fits this well in {:.3}. \
             A bump at one temperature is outside the term library, so the structure is not \
             attributed",
            self.height_dph,
            self.lo_c,
            self.hi_c,
            self.delta_bic,
            family_dbic,
            self.p_family,
            self.p_bump
        );
        let evidence = BumpEvidence {
            lo_c: self.lo_c,
            hi_c: self.hi_c,
            height_dph: self.height_dph,
            delta_bic: self.delta_bic,
            instead_of: f.mechanism(),
            instead_of_delta_bic: family_dbic,
            p_under_family: self.p_family,
            p_under_bump: self.p_bump,
        };
        (note, evidence)
    }
}
