//! The `handgate` binary: parses the command line and runs the subcommand asked for
//! ([`commands`], one function each).

use std::process::ExitCode;

use clap::Parser;
use handgate_gateway::cli::{Cli, Command};

mod commands;

fn main() -> anyhow::Result<ExitCode> {
    match Cli::parse().command {
        Command::Run { profile, overrides } => commands::run::run(profile.into_inner(), overrides),
        Command::Check {
            profile,
            list,
            overrides,
        } => commands::check::check(profile.into_inner(), list, overrides),
        Command::Doctor(cmd) => commands::doctor::doctor(cmd),
        Command::Fleet {
            domains,
            interface,
            seconds,
        } => commands::fleet(&domains, interface.as_deref(), seconds),
        Command::Status {
            dds,
            topic,
            once,
            timeout,
        } => commands::status::status(&dds, &topic, once, timeout),
        Command::List => commands::devices::list(),
        Command::Discover {
            device,
            profile,
            overrides,
        } => commands::devices::discover(&device, profile, overrides),
        Command::Calibrate {
            device,
            profile,
            overrides,
        } => commands::devices::calibrate(&device, profile, overrides),
        Command::Emulate(cmd) => commands::emulate::emulate(cmd),
        Command::Send(cmd) => commands::send::send(cmd),
        Command::Record(cmd) => commands::recording::record(cmd),
        Command::Replay(cmd) => commands::recording::replay(cmd),
        Command::Export(cmd) => commands::recording::export(cmd),
        Command::Security(cmd) => commands::security::security(cmd),
    }
}
