//! `handgate send`: one command in the canonical model to a named device of a running
//! gateway, on its own interface `rt/handgate/{device}/cmd` (bring-up).

use std::process::ExitCode;
use std::time::Duration;

use handgate_gateway::cli::SendCmd;
use handgate_gateway::tools;
use handgate_idl::handgate as hg;

/// Sends the safe state, a closure or joint targets (whichever `cmd` gives), repeated for
/// `--hold` seconds.
pub fn send(cmd: SendCmd) -> anyhow::Result<ExitCode> {
    let node = cmd.dds.node()?;
    let msg = if cmd.safe {
        hg::HandCmd_ {
            mode: hg::MODE_SAFE,
            ..Default::default()
        }
    } else if let Some(c) = cmd.closure {
        hg::HandCmd_ {
            mode: hg::MODE_CLOSURE,
            closure: c,
            ..Default::default()
        }
    } else if !cmd.joint.is_empty() {
        hg::HandCmd_ {
            mode: hg::MODE_JOINTS,
            joints: cmd
                .joint
                .into_iter()
                .map(|(name, q)| hg::JointCmd_ {
                    name,
                    q,
                    kp: cmd.kp,
                    kd: cmd.kd,
                    ..Default::default()
                })
                .collect(),
            ..Default::default()
        }
    } else {
        anyhow::bail!("say what to send: --closure X, --joint NAME=RAD (repeatable) or --safe");
    };
    let n = tools::send(
        &node,
        &cmd.dds.namespace.clone().unwrap_or_default(),
        &cmd.device,
        msg,
        tools::SendOptions {
            timeout: Duration::from_secs_f64(cmd.timeout),
            hold: Duration::from_secs_f64(cmd.hold),
            force: cmd.force,
        },
    )?;
    println!("sent {n} command(s) to {}", cmd.device);
    Ok(ExitCode::SUCCESS)
}
