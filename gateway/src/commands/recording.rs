//! Recordings: `handgate record` (the fleet's DDS traffic into a rosbag2-shaped MCAP
//! directory), `replay` (its messages re-published with their timing) and `export` (its
//! hand streams as an xr_teleoperate episode).

use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use handgate_gateway::cli::{ExportCmd, RecordCmd, ReplayCmd};

use super::{init_logging, load_plan, wait_for_signal, EXIT_INVALID};

/// Records the profile's topics until SIGINT / SIGTERM or `--duration`, then prints what
/// was written.
pub fn record(cmd: RecordCmd) -> anyhow::Result<ExitCode> {
    let (l, plan) = match load_plan(cmd.profile, cmd.overrides) {
        Ok(lp) => lp,
        Err(code) => return Ok(code),
    };
    init_logging(&l.profile.log.level, l.profile.log.format);
    let node = handgate_adapters::dds::Node::new(plan.domain, plan.interface.as_deref())?;
    let topics = handgate_gateway::recording::topics(&plan, &cmd.record.topics);
    let opts =
        handgate_gateway::recording::options(&cmd.name, cmd.record.max_mb, cmd.record.max_seconds, cmd.record.zstd);
    let rec = handgate_record::Recorder::start(&node, topics, opts)?;
    println!(
        "recording {} topic(s) of profile {} on DDS domain {} into {}",
        rec.topics.len(),
        plan.profile,
        plan.domain,
        cmd.name.display()
    );
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(async {
        match cmd.duration {
            Some(d) => tokio::select! {
                r = wait_for_signal() => r.map(|_| ()),
                _ = tokio::time::sleep(Duration::from_secs_f64(d.max(0.0))) => Ok(()),
            },
            None => wait_for_signal().await.map(|_| ()),
        }
    })?;
    let s = rec.stop()?;
    println!(
        "recorded {} message(s), {} dropped, {} bytes of messages in {} file(s)",
        s.messages,
        s.dropped,
        s.bytes,
        s.files.len()
    );
    Ok(ExitCode::SUCCESS)
}

/// Replays a recording on `--domain` (domain 0, a robot's, only with `--allow-robot`: exit 2
/// otherwise) until its end, or in a loop until SIGINT / SIGTERM.
pub fn replay(cmd: ReplayCmd) -> anyhow::Result<ExitCode> {
    if cmd.domain == 0 && !cmd.allow_robot {
        eprintln!(
            "refusing to replay on DDS domain 0 (a robot's): replayed commands move real hands; \
             pass --allow-robot to do it anyway"
        );
        return Ok(ExitCode::from(EXIT_INVALID));
    }
    let bag = handgate_record::bag::Bag::open(&cmd.dir)?;
    for (f, e) in &bag.truncated {
        eprintln!("{}: read up to a damaged record ({e})", f.display());
    }
    let node = handgate_adapters::dds::Node::new(cmd.domain, cmd.interface.as_deref())?;
    let stop = Arc::new(AtomicBool::new(false));
    let s2 = stop.clone();
    let rt = tokio::runtime::Runtime::new()?;
    rt.spawn(async move {
        if wait_for_signal().await.is_ok() {
            s2.store(true, Ordering::Relaxed);
        }
    });
    let opts = handgate_record::replay::ReplayOptions {
        rate: cmd.rate,
        looped: cmd.looped,
        topics: cmd.topics,
        wait_match: Duration::from_secs_f64(cmd.wait.max(0.0)),
        readers: cmd.readers,
        settle: Duration::from_millis(cmd.settle_ms),
    };
    println!("replaying {} on DDS domain {}", cmd.dir.display(), cmd.domain);
    let s = handgate_record::replay::replay(&node, &bag, &opts, || stop.load(Ordering::Relaxed))?;
    for t in &s.unmatched {
        eprintln!(
            "{t}: fewer than {} reader(s) matched when the replay started",
            cmd.readers
        );
    }
    println!(
        "replayed {} message(s) on {} topic(s), {} pass(es)",
        s.published,
        s.topics.len(),
        s.passes
    );
    rt.shutdown_timeout(Duration::from_millis(100));
    Ok(ExitCode::SUCCESS)
}

/// Writes a recording's hand streams as xr_teleoperate episode JSON, to `--output` or stdout.
pub fn export(cmd: ExportCmd) -> anyhow::Result<ExitCode> {
    let bag = handgate_record::bag::Bag::open(&cmd.dir)?;
    let opts = handgate_record::export::ExportOptions {
        rate_hz: cmd.rate,
        left: (!cmd.only_right).then_some(cmd.left),
        right: (!cmd.only_left).then_some(cmd.right),
    };
    let v = handgate_record::export::xr_teleoperate(&bag, &opts)?;
    let text = serde_json::to_string_pretty(&v)?;
    match cmd.output {
        Some(p) => {
            std::fs::write(&p, text)?;
            println!("wrote {}", p.display());
        }
        None => println!("{text}"),
    }
    Ok(ExitCode::SUCCESS)
}
