use std::process::ExitCode;

use clap::Parser;
use handgate_gateway::cli::{Cli, Command};
use handgate_gateway::profile::{self, LoadOptions, LogFormat};

/// Exit code for an invalid profile: nothing was started.
const EXIT_INVALID: u8 = 2;

fn load(profile: Option<String>, overrides: handgate_gateway::cli::OverrideArgs) -> Result<profile::Loaded, ExitCode> {
    profile::load(&LoadOptions {
        profile,
        overrides: overrides.into(),
        ..LoadOptions::default()
    })
    .map_err(|e| {
        for line in e.lines() {
            eprintln!("{line}");
        }
        ExitCode::from(EXIT_INVALID)
    })
}

fn main() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        Command::Check { list: true, .. } => {
            for p in profile::list_profiles(&handgate_gateway::cli::profile_dirs()) {
                println!("{:<16} {:<40} {}", p.name, p.origin.to_string(), p.description);
            }
        }
        Command::Check { profile, overrides, .. } => match load(profile, overrides) {
            Ok(l) => print!("{}", profile::render_fleet(&l.profile, &l.origin)),
            Err(code) => return Ok(code),
        },
        Command::Run { profile, overrides } => {
            let l = match load(profile, overrides) {
                Ok(l) => l,
                Err(code) => return Ok(code),
            };
            let filter = tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(&l.profile.log.level));
            let fmt = tracing_subscriber::fmt().with_env_filter(filter);
            match l.profile.log.format {
                LogFormat::Human => fmt.init(),
                LogFormat::Json => fmt.json().init(),
            }
            print!("{}", profile::render_fleet(&l.profile, &l.origin));
            let dds = &l.profile.dds;
            let node = handgate_adapters::dds::Node::new(dds.domain.0, dds.interface.as_deref())?;
            tracing::info!(
                domain = node.domain_id(),
                profile = %l.profile.name,
                "handgate started (devices and fronts are not started yet)"
            );
            let rt = tokio::runtime::Runtime::new()?;
            rt.block_on(async { tokio::signal::ctrl_c().await })?;
            tracing::info!("stopped");
        }
    }
    Ok(ExitCode::SUCCESS)
}
