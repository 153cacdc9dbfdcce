//! Cross-crate tests live in `tests/tests/`; this library holds what they (and the CLI's
//! end-to-end runs) share.
//!
//! * [`replay`]: the firmware's replay file format (writer and reader) and the QEMU scenario.
//! * [`e2e`]: the README's main job (train, export, run the board image, compare).
//! * [`firmware`]: build the board image for a replay file, run it in QEMU, decode its output.

pub mod e2e;
pub mod firmware;
pub mod replay;
