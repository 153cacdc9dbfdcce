//! Candidate block columns kept across the passes of one diagnosis.

use std::collections::HashMap;
use std::sync::Arc;

use crate::candidates::Family;
use crate::DiagnoseError;

/// Candidate block columns that do not depend on the model (every family but the sensor's
/// lag and quantisation, which change the baseline's drive), kept across the passes of one
/// diagnosis: each pass after a finding scans the same grid against a larger model, and on
/// a month at 1 Hz rebuilding the columns cost 18 s per pass.
#[derive(Debug, Default)]
pub(crate) struct ColumnCache(std::sync::Mutex<HashMap<ColumnKey, Arc<Vec<Vec<f64>>>>>);

/// A candidate point: its family's index and the bits of its non-linear parameters.
type ColumnKey = (usize, Vec<u64>);

impl ColumnCache {
    pub(super) fn get_or_build(
        &self,
        family: Family,
        nl: &[f64],
        build: impl FnOnce() -> Result<Vec<Vec<f64>>, DiagnoseError>,
    ) -> Result<Arc<Vec<Vec<f64>>>, DiagnoseError> {
        // The sensor's families depend on the model; periodic columns are closed-form sums,
        // cheaper to rebuild than the 160 MB the grid's columns hold on a month.
        if matches!(
            family,
            Family::SensorLag | Family::TempQuantization | Family::Periodic
        ) {
            return build().map(Arc::new);
        }
        let key = (family.index(), nl.iter().map(|v| v.to_bits()).collect());
        if let Some(c) = self.0.lock().ok().and_then(|m| m.get(&key).cloned()) {
            return Ok(c);
        }
        // Shared with the scan's points, not copied: on a month the grid's raw columns are
        // hundreds of MB.
        let c = Arc::new(build()?);
        if let Ok(mut m) = self.0.lock() {
            m.insert(key, Arc::clone(&c));
        }
        Ok(c)
    }
}
