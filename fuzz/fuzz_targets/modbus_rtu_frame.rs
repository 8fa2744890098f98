#![no_main]
//! See handgate_fuzz::modbus_rtu_frame.
libfuzzer_sys::fuzz_target!(|data: &[u8]| handgate_fuzz::modbus_rtu_frame(data));
