//! The model as given, its linear parameters fitted to the block means: the null hypothesis
//! every pass of the search tests a candidate against.

use std::borrow::Cow;

use super::candidates::Family;
use super::linalg::Basis;
use super::noise::reml::reml_noise;
use super::prepare::{model_drive, DriveSeries, PhysicsModel, Prepared};
use super::ramp::BlockRecord;
use super::DiagnoseError;
use rlg_simulate::noise::NoiseParams;

/// A model's least-squares fit to a prepared record's block means.
pub(crate) struct Baseline<'a> {
    /// The record.
    pub(crate) prep: &'a Prepared,
    /// The model whose linear parameters are fitted.
    pub(crate) model: &'a PhysicsModel,
    /// The drive the model sees ([`model_drive`]: de-quantised or un-lagged where the model
    /// says so).
    pub(crate) drive: Cow<'a, DriveSeries>,
    /// Block means of each linear parameter's column.
    pub(crate) cols_b: Vec<Vec<f64>>,
    /// Their orthonormal basis.
    pub(crate) ols: Basis,
    /// The fitted linear parameters.
    pub(crate) beta_b: Vec<f64>,
    /// The block means' residual, °/h.
    pub(crate) resid_b: Vec<f64>,
}

impl<'a> Baseline<'a> {
    /// Fits `model`'s linear parameters to `prep`'s block means.
    pub(crate) fn fit(prep: &'a Prepared, model: &'a PhysicsModel) -> Result<Self, DiagnoseError> {
        let drive = model_drive(model, prep)?;
        let cols_b = prep.baseline_blocks(model, &drive);
        let ols = Basis::new(&cols_b);
        let beta_b = ols.coefficients(&prep.y_b);
        let resid_b = ols.residual(&prep.y_b);
        Ok(Self {
            prep,
            model,
            drive,
            cols_b,
            ols,
            beta_b,
            resid_b,
        })
    }

    /// Length of a block, s.
    pub(crate) fn block_s(&self) -> f64 {
        self.prep.block as f64 * self.prep.dt_s
    }

    /// The block columns of `family` at non-linear parameters `nl` beside this fit
    /// ([`Family::block_columns`]).
    pub(crate) fn candidate_blocks(
        &self,
        family: Family,
        nl: &[f64],
    ) -> Result<Vec<Vec<f64>>, DiagnoseError> {
        family.block_columns(nl, self.prep, self.model, &self.drive, &self.beta_b)
    }

    /// The per-sample columns of `family` at `nl` beside this fit ([`Family::columns`]).
    pub(crate) fn candidate_columns(
        &self,
        family: Family,
        nl: &[f64],
    ) -> Result<Vec<Vec<f64>>, DiagnoseError> {
        family.columns(nl, self.prep, self.model, &self.drive, &self.beta_b)
    }

    /// The gyro noise fitted by REML to the residual of this fit, rate random walk allowed
    /// or not ([`reml_noise`]).
    pub(crate) fn reml_noise(&self, with_rrw: bool) -> Option<NoiseParams> {
        reml_noise(
            &self.cols_b,
            &self.prep.y_b,
            self.prep.block,
            self.prep.dt_s,
            with_rrw,
        )
    }

    /// The block means and this fit's columns, as the slow tests take them.
    pub(crate) fn block_record(&self) -> BlockRecord<'_> {
        BlockRecord {
            base_b: &self.cols_b,
            y_b: &self.prep.y_b,
            block: self.prep.block,
            dt_s: self.prep.dt_s,
        }
    }
}
