//! Fuzz target: `tests::fuzz_checks::model_file`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| tests::fuzz_checks::model_file(data));
