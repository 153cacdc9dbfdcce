//! The numbers Yu et al., Chin. Opt. Lett. 9(5) 051201 (2011) publish, in one place: the
//! coefficients of Eq. (11), the latitude of the test, and the figures of merit of Sec. 4 and
//! Table 1. Table 1's measurements themselves are the bundled CSV (`rlg_io::table1`); the
//! shipped TOML files that restate Eq. (11) (`models/paper.toml`,
//! `scenarios/yu2011-dynamic.toml`) are held to these constants by tests.

/// Eq. (11), the stepwise-regression bias model: B = Σ c_k·T^k + a·Ṫ + b·Ṫ³ + d·T·Ṫ, B in °/h,
/// T the body temperature in °C, Ṫ = dT/dt in °C/s (see `baselines::eq11` for the unit).
pub mod eq11 {
    /// c_0 … c_3 of the cubic in T, °/h per °C^k (c_0, −0.00960 °/h, is the room-temperature
    /// calibration term).
    pub const STATIC_POLY_DPH: [f64; 4] = [-0.00960, 7.1445e-4, -2.6387e-5, 2.1772e-7];
    /// a, °/h per (°C/s).
    pub const RATE_LINEAR: f64 = 2.1572;
    /// b, °/h per (°C/s)³.
    pub const RATE_CUBIC: f64 = -4.2769e3;
    /// d, °/h per (°C·°C/s).
    pub const TEMP_RATE: f64 = 1.9163e-5;
}

/// Latitude of the test (Changsha), degrees north: the Earth rate along the vertical axis in
/// Table 1's output level.
pub const LATITUDE_DEG: f64 = 28.2;

/// 100 s bias stability of the raw dynamic-test output, °/h.
pub const RAW_B100_DPH: f64 = 0.0102;
/// 100 s bias stability after the stepwise-regression model, Eq. (11), °/h.
pub const STEPWISE_B100_DPH: f64 = 0.0016;
/// 100 s bias stability after the LS-SVM model, °/h.
pub const LSSVM_B100_DPH: f64 = 0.0011;
/// Largest static error of the least-squares quadratic (Table 1: 13.8e-4 °/h).
pub const STATIC_QUAD_MAX_ERR_DPH: f64 = 13.8e-4;
/// Largest static error of the LS-SVM (Table 1: 7.28e-4 °/h).
pub const STATIC_LSSVM_MAX_ERR_DPH: f64 = 7.28e-4;
