#![no_main]
//! See handgate_fuzz::cdr_decode.
libfuzzer_sys::fuzz_target!(|data: &[u8]| handgate_fuzz::cdr_decode(data));
