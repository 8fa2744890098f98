//! Command line.

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(
    name = "handgate",
    version,
    about = "One gateway for a mixed fleet of robot hands and grippers"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the gateway.
    Run {
        /// DDS domain id (the simulated fleet uses 1 so it cannot move a robot on domain 0).
        #[arg(long, default_value_t = 1)]
        domain: u32,
    },
}
