//! The files of a whole IMU (`rlg calibrate --every-axis`): `imu.h`, which includes every
//! calibrated axis' C header, and `imu.rs`, which holds every axis' Rust table in a module of
//! the axis' name.

use std::fmt::Write as _;
use std::path::Path;

use rlg_train::export_c::CName;

use super::write_text;
use crate::CalibrateError;

/// One calibrated axis: its folder (also its Rust module's name) and its C symbol prefix.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImuAxis {
    /// Folder under `--out` and Rust module name (`imu_gyro_x`).
    pub slug: String,
    /// The C header's symbol prefix (`rlg_imu_gyro_x`).
    pub c_name: CName,
}

/// Writes `imu.h` and `imu.rs` into `dir` for `axes`; returns their names.
pub fn write_imu(dir: &Path, axes: &[ImuAxis]) -> Result<[&'static str; 2], CalibrateError> {
    write_text(&dir.join("imu.h"), &imu_header(axes))?;
    write_text(&dir.join("imu.rs"), &imu_module(axes))?;
    Ok(["imu.h", "imu.rs"])
}

/// `imu.h`: one include per calibrated axis, so a firmware takes the IMU's tables at once.
pub fn imu_header(axes: &[ImuAxis]) -> String {
    let mut h = String::from(
        "/* The board tables of every calibrated gyro axis; written by rlg calibrate \
         --every-axis. */\n#ifndef RLG_IMU_TABLES_H\n#define RLG_IMU_TABLES_H\n\n",
    );
    for a in axes {
        let _ = writeln!(h, "#include \"{}/table.h\" /* {}_* */", a.slug, a.c_name);
    }
    h.push_str("\n#endif\n");
    h
}

/// `imu.rs`: one module per calibrated axis holding its `table.rs` (its `MODEL` and reference
/// constants), so a firmware crate takes the IMU's tables with one `mod imu;` beside the axis
/// folders.
pub fn imu_module(axes: &[ImuAxis]) -> String {
    let mut s = String::from(
        "//! The board tables of every calibrated gyro axis; written by `rlg calibrate \
         --every-axis`.\n//! Each module holds its axis' `MODEL` (a `compensator_core::ModelTable`) \
         and reference constants.\n",
    );
    for a in axes {
        let _ = write!(
            s,
            "\n/// The table of axis `{0}` (`{0}/table.rs`).\npub mod {0} {{\n    include!(\"{0}/table.rs\");\n}}\n",
            a.slug
        );
    }
    s
}
