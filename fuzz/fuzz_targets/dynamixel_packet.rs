#![no_main]
//! See handgate_fuzz::dynamixel_packet.
libfuzzer_sys::fuzz_target!(|data: &[u8]| handgate_fuzz::dynamixel_packet(data));
