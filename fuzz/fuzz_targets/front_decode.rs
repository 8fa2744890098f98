#![no_main]
//! See handgate_fuzz::front_decode.
libfuzzer_sys::fuzz_target!(|data: &[u8]| handgate_fuzz::front_decode(data));
