//! `handgate status`: a live table of a running gateway's devices, from its status topic, and
//! of its fronts, from the status extension.

use std::process::ExitCode;
use std::time::Duration;

use handgate_gateway::cli::DdsArgs;
use handgate_gateway::tools;

/// Reads `topic` (in `--namespace`) and prints each sample as a table, the screen cleared
/// between them; with `once`, one sample and exit. An error when no sample comes within
/// `timeout` seconds.
pub fn status(dds: &DdsArgs, topic: &str, once: bool, timeout: f64) -> anyhow::Result<ExitCode> {
    let node = dds.node()?;
    let mut reader = tools::StatusReader::new(&node, &dds.topic(topic))?;
    loop {
        let (s, ext) = reader.next(Duration::from_secs_f64(timeout))?;
        if !once {
            print!("\x1b[2J\x1b[H");
        }
        print!("{}{}", tools::render_status(&s), tools::render_fronts(ext.as_ref()));
        if once {
            return Ok(ExitCode::SUCCESS);
        }
    }
}
