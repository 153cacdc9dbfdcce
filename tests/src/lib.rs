//! Cross-crate tests live in `tests/tests/`; this library holds what they (and the CLI's
//! end-to-end runs) share.
//!
//! * [`replay`]: the firmware's replay file format (writer and reader) and the QEMU scenario.
//! * [`e2e`]: the README's main job (train, export, run the board image, compare).
//! * [`budgets`]: board budgets (instructions, flash, RAM, stack) measured in QEMU.
//! * [`capi`]: the C API's library, C programs built against it, the held-out record.
//! * [`firmware`]: build the board image for a replay file, run it in QEMU, decode its output.
//! * [`fuzz_checks`]: the properties the fuzz targets check, replayed on the kept corpus.

pub mod budgets;
pub mod c_header;
pub mod capi;
pub mod e2e;
pub mod firmware;
pub mod fuzz_checks;
pub mod replay;

/// Support vectors in the committed default board table.
pub const DEFAULT_TABLE_SV: usize = default_table::MODEL.support.len();

/// The committed default board table (`firmware/src/model_table.rs`), compiled in here.
pub fn default_model_table() -> &'static compensator_core::ModelTable<
    { default_table::MODEL.support.len() },
    { default_table::MODEL.spec.features.len() },
> {
    &default_table::MODEL
}

#[allow(dead_code, missing_docs)]
#[path = "../../firmware/src/model_table.rs"]
mod default_table;
