//! handgate adapters: the [`HandDevice`](device::HandDevice) trait, the canonical command
//! model, and one folder per device kind (codec, transport, emulator, adapter).

pub mod dds;
pub mod ezgripper;
pub mod sim;
