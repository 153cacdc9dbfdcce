//! PLACEHOLDER model table, written by hand, not trained: it only has the shape of the table
//! the trainer exports (2 features: temperature °C and dT/dt °C/s) so that the image builds and
//! the QEMU replay test exercises every code path. The trainer's export replaces this file with
//! a generated one (`// @generated` header naming the command).
//!
//! Its trained range (12…60 °C, ±0.025 °C/s) is deliberately narrower than the replay test's
//! 10…65 °C ramp so that `OUT_OF_RANGE` occurs.

/// The model flashed with the image (placeholder, see the module docs).
pub const MODEL: compensator_core::ModelTable<6, 2> = compensator_core::ModelTable {
    spec: compensator_core::ModelSpec {
        features: [
            compensator_core::Feature::TempC,
            compensator_core::Feature::TempRateCPerS,
        ],
        input_mean: [37.5, 0.0],
        input_inv_scale: [0.0625, 80.0],
        input_lo: [12.0, -0.025],
        input_hi: [60.0, 0.025],
        gamma: 0.5,
        bias_dph: -7.0,
        reference_dph: -7.0,
        // τ = 60 s at 1 Hz: α = 1 − e^(−2/60), β = (1 − e^(−1/60))², warm-up 5τ.
        rate_filter: compensator_core::RateFilter {
            alpha: 0.032_783_9,
            beta: 0.000_273_193,
            dt_s: 1.0,
            warmup_samples: 300,
        },
    },
    support: [
        [-1.5, 0.0],
        [-0.5, 0.0],
        [0.5, 0.0],
        [1.5, 0.0],
        [0.0, -1.0],
        [0.0, 1.0],
    ],
    alpha_dph: [0.05, -0.02, 0.03, -0.04, 0.01, -0.01],
};
