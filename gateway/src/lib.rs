//! handgate gateway: router, fronts, profiles, runtime and CLI.

pub mod cli;
pub mod fronts;
pub mod router;
