//! Host-side toolchain for temperature compensation of ring-laser-gyro bias.
pub mod recording;
