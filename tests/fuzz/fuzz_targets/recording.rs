//! Fuzz target: `tests::fuzz_checks::recording`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| tests::fuzz_checks::recording(data));
