//! Command line.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

use crate::profile::{CliOverrides, LogFormat};

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
        /// Profile: a shipped name (see `handgate check --list`), NAME for
        /// profiles/NAME.toml or $HANDGATE_PROFILE_DIR/NAME.toml, or a path to a .toml
        /// file. Without it: the embedded default (the simulated fleet on DDS domain 1).
        #[arg(long)]
        profile: Option<String>,
        #[command(flatten)]
        overrides: OverrideArgs,
    },
    /// Validate a profile and print the resolved fleet (exit 0 valid, 2 invalid).
    Check {
        /// Profile to check (as for `run --profile`); without it: the embedded default.
        profile: Option<String>,
        /// List the profiles that can be named instead of checking one.
        #[arg(long, conflicts_with = "profile")]
        list: bool,
        #[command(flatten)]
        overrides: OverrideArgs,
    },
}

/// Flags that override profile keys (above the profile file and `HANDGATE_*` variables).
#[derive(Debug, Clone, Default, Args)]
pub struct OverrideArgs {
    /// DDS domain id (`dds.domain`).
    #[arg(long)]
    pub domain: Option<u32>,
    /// Network interface for DDS (`dds.interface`), e.g. eth0.
    #[arg(long)]
    pub interface: Option<String>,
    /// Log format (`log.format`).
    #[arg(long, value_enum)]
    pub log_format: Option<LogFormatArg>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LogFormatArg {
    Human,
    Json,
}

impl From<OverrideArgs> for CliOverrides {
    fn from(a: OverrideArgs) -> Self {
        CliOverrides {
            domain: a.domain,
            interface: a.interface,
            log_format: a.log_format.map(|f| match f {
                LogFormatArg::Human => LogFormat::Human,
                LogFormatArg::Json => LogFormat::Json,
            }),
        }
    }
}

/// The directories `--profile NAME` searches (see `profile::default_search_dirs`).
pub fn profile_dirs() -> Vec<PathBuf> {
    crate::profile::default_search_dirs()
}
