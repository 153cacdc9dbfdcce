//! Fuzz target: `tests::fuzz_checks::core_update`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| tests::fuzz_checks::core_update(data));
