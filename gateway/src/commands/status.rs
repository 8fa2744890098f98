//! `handgate status`: a live table of a running gateway's devices, from its status topic.

use std::process::ExitCode;
use std::time::Duration;

use handgate_gateway::cli::DdsArgs;
use handgate_gateway::tools;

/// Reads `topic` (in `--namespace`) and prints each sample as a table, the screen cleared
/// between them; with `once`, one sample and exit. An error when no sample comes within
/// `timeout` seconds.
pub fn status(dds: &DdsArgs, topic: &str, once: bool, timeout: f64) -> anyhow::Result<ExitCode> {
    let node = handgate_adapters::dds::Node::new(dds.domain, dds.interface.as_deref())?;
    loop {
        let s = tools::status_once(&node, &dds.topic(topic), Duration::from_secs_f64(timeout))?;
        if !once {
            print!("\x1b[2J\x1b[H");
        }
        print!("{}", tools::render_status(&s));
        if once {
            return Ok(ExitCode::SUCCESS);
        }
    }
}
