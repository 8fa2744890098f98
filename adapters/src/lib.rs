//! handgate adapters: the [`HandDevice`](device::HandDevice) trait, the canonical command
//! model, the table-driven mapping, the device-kind registry ([`kind`], [`kinds::KINDS`]) and
//! one folder per device kind (its factory and profile keys, codec, transport, emulator,
//! adapter).

pub mod brainco;
pub mod control;
pub mod dds;
pub mod dds_device;
pub mod dds_security;
pub mod device;
pub mod dex1;
pub mod dex3;
pub mod dex5;
pub mod discovery;
pub mod dynamixel;
pub mod emu_common;
pub mod ezgripper;
pub mod front;
pub mod fronts;
pub mod hand_sdk;
pub mod inspire_dfx;
pub mod inspire_ftp;
pub mod inspire_rh56;
pub mod kind;
pub mod kinds;
pub mod leap;
pub mod link;
pub mod loops;
pub mod mapping;
pub mod modbus;
pub mod model;
pub mod motion;
pub mod netif;
pub mod open;
pub mod realtime;
pub mod robotiq;
pub mod rohand;
pub mod ros;
pub mod route;
pub mod serial;
pub mod service_client;
pub mod service_emulator;
pub mod sim;
pub mod units;
