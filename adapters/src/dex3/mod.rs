pub mod dds_service_emulator;
