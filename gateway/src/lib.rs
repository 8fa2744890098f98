//! handgate gateway: router, fronts, profiles, runtime and CLI.

pub mod cli;
pub mod profile;
