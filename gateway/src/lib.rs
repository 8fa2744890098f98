//! handgate gateway: router, fronts, profiles, runtime and CLI.

pub mod cli;
pub mod diagnostics;
pub mod doctor;
pub mod fleet;
pub mod health;
pub mod http;
#[cfg(feature = "foxglove")]
pub mod live;
pub mod plan;
pub mod profile;
pub mod recording;
pub mod resolve;
pub mod runtime;
pub mod security;
pub mod systemd;
pub mod ticker;
pub mod tools;
