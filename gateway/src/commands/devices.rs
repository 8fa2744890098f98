//! Bring-up subcommands that reach devices directly, not through a running gateway:
//! `handgate list` (what is attached to this machine), `discover` and `calibrate` (one
//! device of a profile, opened alone through its kind).

use std::process::ExitCode;

use handgate_adapters::kind::DeviceKind;
use handgate_gateway::cli::OverrideArgs;

use super::with_device;

/// `handgate list`: the devices each kind can enumerate, with permission problems explained.
pub fn list() -> anyhow::Result<ExitCode> {
    for kind in DeviceKind::all() {
        if let Some(found) = kind.factory().list_attached() {
            for line in found? {
                println!("{line}");
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// `handgate discover`: the wiring `device` answers from, as a profile snippet.
pub fn discover(device: &str, profile: Option<String>, overrides: OverrideArgs) -> anyhow::Result<ExitCode> {
    with_device(
        profile,
        overrides,
        device,
        |d| async move {
            let Some(ability) = d.discovery() else {
                anyhow::bail!("device {} ({}) has no wiring discovery", d.info().name, d.info().kind);
            };
            Ok(ability.discover().await?)
        },
        |out| print!("{out}"),
    )
}

/// `handgate calibrate`: runs `device`'s calibration and prints what to put in the profile.
pub fn calibrate(device: &str, profile: Option<String>, overrides: OverrideArgs) -> anyhow::Result<ExitCode> {
    with_device(
        profile,
        overrides,
        device,
        |d| async move {
            let Some(ability) = d.calibration() else {
                anyhow::bail!("device {} ({}) has no calibration", d.info().name, d.info().kind);
            };
            Ok(ability.calibrate().await?)
        },
        |out| println!("{device} calibrated: {out}"),
    )
}
