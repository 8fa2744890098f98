#![no_main]
//! See handgate_fuzz::dex3_state_frame.
libfuzzer_sys::fuzz_target!(|data: &[u8]| handgate_fuzz::dex3_state_frame(data));
