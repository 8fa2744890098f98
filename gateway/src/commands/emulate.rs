//! `handgate emulate <kind>`: a kind's emulator as a standalone process. Everything the
//! subcommand does is here, so how options reach a kind changes in this file only.

use std::process::ExitCode;

use handgate_adapters::kind::{DeviceKind, Emulation};
use handgate_gateway::cli::EmulateCmd;

use super::{wait_for_signal, LOG_TARGET};

/// Starts `cmd.kind`'s emulator with the command's options, prints what it stands for and
/// runs until it ends (a blocking emulator) or until SIGINT / SIGTERM.
pub fn emulate(cmd: EmulateCmd) -> anyhow::Result<ExitCode> {
    // `inspire-rh56` names `inspire_rh56`: the and the shell's spelling.
    let Some(kind) = DeviceKind::by_name(&cmd.kind).or_else(|| DeviceKind::by_name(&cmd.kind.replace('-', "_"))) else {
        anyhow::bail!(
            "unknown kind {:?} (kinds: {})",
            cmd.kind,
            DeviceKind::names().join(", ")
        );
    };
    let args = handgate_adapters::kind::EmulateArgs::try_from(cmd).map_err(|e| anyhow::anyhow!(e))?;
    let (what, emulation) = kind.factory().emulate(&args)?;
    println!("{what}");
    match emulation {
        Emulation::Blocking(run) => run()?,
        Emulation::Running(keep) => {
            let rt = tokio::runtime::Runtime::new()?;
            let sig = rt.block_on(wait_for_signal())?;
            tracing::info!(target: LOG_TARGET, signal = sig, "stopping the emulator");
            drop(keep);
        }
    }
    Ok(ExitCode::SUCCESS)
}
