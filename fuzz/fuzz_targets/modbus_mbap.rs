#![no_main]
//! See handgate_fuzz::modbus_mbap.
libfuzzer_sys::fuzz_target!(|data: &[u8]| handgate_fuzz::modbus_mbap(data));
