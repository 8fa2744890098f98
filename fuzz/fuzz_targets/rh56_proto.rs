#![no_main]
//! See handgate_fuzz::rh56_proto.
libfuzzer_sys::fuzz_target!(|data: &[u8]| handgate_fuzz::rh56_proto(data));
