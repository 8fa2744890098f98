#![no_main]
//! See handgate_fuzz::robotiq_front.
libfuzzer_sys::fuzz_target!(|data: &[u8]| handgate_fuzz::robotiq_front(data));
