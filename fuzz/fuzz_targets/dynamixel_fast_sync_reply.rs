#![no_main]
//! See handgate_fuzz::dynamixel_fast_sync_reply.
libfuzzer_sys::fuzz_target!(|data: &[u8]| handgate_fuzz::dynamixel_fast_sync_reply(data));
