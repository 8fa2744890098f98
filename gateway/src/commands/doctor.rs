//! `handgate doctor`: why clients do not match the profile's gateway (the look itself is
//! [`handgate_gateway::doctor`]).

use std::process::ExitCode;

use handgate_gateway::cli::DoctorCmd;
use handgate_gateway::doctor;

use super::load_plan;

/// Exit 0 when nothing is wrong, 1 otherwise, 2 for an invalid profile; `--count-only`
/// prints only `relevant N` (the interface sweep's child).
pub fn doctor(cmd: DoctorCmd) -> anyhow::Result<ExitCode> {
    let listen = doctor::listen_time(cmd.seconds).map_err(anyhow::Error::msg)?;
    let scan = match (cmd.no_scan, cmd.scan) {
        (true, _) => Vec::new(),
        (false, Some(s)) => doctor::parse_scan(&s).map_err(|e| anyhow::anyhow!("--scan {s}: {e}"))?,
        (false, None) => doctor::default_scan(),
    };
    let sweep = (!cmd.no_sweep && !cmd.count_only)
        .then(|| {
            std::env::current_exe().ok().map(|exe| doctor::Sweep {
                exe,
                profile: cmd.profile.clone(),
            })
        })
        .flatten();
    let (loaded, plan) = match load_plan(cmd.profile, cmd.overrides) {
        Ok(lp) => lp,
        Err(code) => return Ok(code),
    };
    let scan = if cmd.count_only { Vec::new() } else { scan };
    let mut out = doctor::run(&plan, &doctor::Options { listen, scan, sweep })?;
    if cmd.count_only {
        println!("relevant {}", out.relevant);
        return Ok(ExitCode::SUCCESS);
    }
    let security = doctor::security_targets(&loaded.profile, &plan);
    doctor::add_security(&mut out, &security, handgate_gateway::security::time::now());
    print!("{}", out.text);
    Ok(if out.problems.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
