//! Benchmark 3: the end-to-end hop. A client publishes unitree_hg `HandCmd_` with a tag in
//! `reserve[0]` and times the first `HandState_` whose `reserve[0]` carries that tag, against
//! a peer: the gateway (its Dex3 front on the emulated hand), the floor (a Rust echo that
//! answers each command at once from the DDS listener) or the Python relay (unitree_sdk2py).

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use handgate_adapters::dds::{Node, Qos};
use handgate_idl::unitree_hg::{HandCmd_, HandState_, DEX3_MOTORS, DEX3_PRESS_SENSORS};
use handgate_idl::TopicType;
use serde::{Deserialize, Serialize};

use crate::stats::{cpu_seconds, Summary};

/// One client run against one peer at one command rate.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct HopResult {
    pub target: String,
    pub rate_hz: f64,
    /// Commands sent after the warm-up.
    pub sent: usize,
    /// Of those, how many came back tagged (the rest were superseded by a newer command
    /// before a state reflected them, or lost).
    pub echoed: usize,
    /// Latency, µs.
    pub latency_us: Option<Summary>,
    /// CPU of the peer process during the run, % of one core.
    pub peer_cpu_pct: f64,
}

impl HopResult {
    /// The report's first cells: path, command rate, sent, echoed, median, p90, p99, max.
    pub fn cells(&self) -> String {
        let lat = self
            .latency_us
            .as_ref()
            .map(|s| crate::report::row4(s, crate::report::us))
            .unwrap_or_else(|| "— | — | — | —".into());
        format!(
            "{} | {:.0} Hz | {} | {} | {lat}",
            self.target, self.rate_hz, self.sent, self.echoed
        )
    }
}

/// A valid Dex3 left-hand command (RIS mode: motor id i, FOC), all joints at their
/// position 0 with a light hold.
fn command(tag: u32) -> HandCmd_ {
    let mut c = HandCmd_::with_motors(DEX3_MOTORS);
    for (i, m) in c.motor_cmd.iter_mut().enumerate() {
        m.mode = 0x10 | i as u8;
        m.kp = 0.5;
        m.kd = 0.1;
    }
    c.reserve[0] = tag;
    c
}

#[allow(clippy::too_many_arguments)]
pub fn client(
    node: &Node,
    target: &str,
    cmd_topic: &str,
    state_topic: &str,
    rate_hz: f64,
    samples: usize,
    warmup: usize,
    peer_pid: u32,
) -> anyhow::Result<HopResult> {
    let run = tagged_client(
        node,
        cmd_topic,
        state_topic,
        rate_hz,
        samples,
        warmup,
        &[peer_pid],
        command,
        |s: &HandState_| Some(s.reserve[0]),
    )?;
    Ok(HopResult {
        target: target.into(),
        rate_hz,
        sent: run.sent,
        echoed: run.latency_us.len(),
        latency_us: Summary::of(&run.latency_us),
        peer_cpu_pct: run.cpu_pct[0],
    })
}

/// What one run of [`tagged_client`] measured.
#[derive(Debug, Clone)]
pub struct TaggedRun {
    /// Commands sent after the warm-up.
    pub sent: usize,
    /// Latency of each of those a state came back for, µs.
    pub latency_us: Vec<f64>,
    /// CPU of each watched process during the run, % of one core (NaN if unreadable).
    pub cpu_pct: Vec<f64>,
}

/// Commands per phase of the client's grid ([`tagged_client`]).
pub const REPHASE_EVERY: usize = 50;
/// The span a new phase is drawn from: a multiple of every peer clock's period here (the
/// emulated G1 hand service's 2 ms tick, the Dex3 loop's 1 ms).
pub const REPHASE_SPAN: Duration = Duration::from_millis(4);

/// The tagged client every hop benchmark runs: publishes `make(tag)` on `cmd_topic` at
/// `rate_hz` (a unique tag per command, each at a uniformly random point of its period, the
/// grid itself moved to a random phase every [`REPHASE_EVERY`] commands) and
/// times the first sample on `state_topic` whose `tag_of` is that tag (timestamps taken in
/// the client's DDS listener). Stops once `samples` commands after the `warmup` ones came
/// back (or 4 × `samples` were sent); the CPU of `pids` is measured over the sending.
#[allow(clippy::too_many_arguments)]
pub fn tagged_client<C, S, M, T>(
    node: &Node,
    cmd_topic: &str,
    state_topic: &str,
    rate_hz: f64,
    samples: usize,
    warmup: usize,
    pids: &[u32],
    make: M,
    tag_of: T,
) -> anyhow::Result<TaggedRun>
where
    C: TopicType,
    S: TopicType + Clone + 'static,
    M: Fn(u32) -> C,
    T: Fn(&S) -> Option<u32> + Send + 'static,
{
    let max_sent = warmup + 4 * samples;
    // Tags unique to this run: a time-derived base, then one per command.
    let base: u32 = 1 + (SystemTime::now().duration_since(UNIX_EPOCH)?.as_millis() % 3000) as u32 * 1_000_000;
    let recv: Arc<Mutex<Vec<Option<Instant>>>> = Arc::new(Mutex::new(vec![None; max_sent]));
    let r = recv.clone();
    let reader = node.reader_with_callback::<S, _>(state_topic, Qos::BestEffort, move |h| {
        let now = Instant::now();
        let mut v = Vec::new();
        h.take_into(&mut v);
        let mut g = r.lock().unwrap_or_else(|e| e.into_inner());
        for s in v {
            let Some(tag) = tag_of(&s) else { continue };
            let i = tag.wrapping_sub(base) as usize;
            if let Some(slot) = g.get_mut(i) {
                slot.get_or_insert(now);
            }
        }
    })?;
    let mut writer = node.writer::<C>(cmd_topic, Qos::Reliable { depth: 16 })?;
    writer.wait_matched(1, Duration::from_secs(30))?;
    reader.wait_matched(1, Duration::from_secs(30))?;

    let period = Duration::from_secs_f64(1.0 / rate_hz);
    let mut sent_at: Vec<Instant> = Vec::with_capacity(max_sent);
    let c0: Vec<f64> = pids.iter().map(|&p| cpu_seconds(p).unwrap_or(f64::NAN)).collect();
    let t0 = Instant::now();
    let mut anchor = t0;
    let mut i = 0usize;
    // Each command goes out at a uniformly random point of its period (xorshift64), so its
    // phase against the 1 kHz device loop is uniform, as for an unsynchronised client; with
    // exact periods the two clocks lock and every command waits the same fixed fraction of
    // a cycle.
    let mut rng: u64 = 0x9E37_79B9_7F4A_7C15 ^ u64::from(base);
    let mut uniform = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    while i < max_sent {
        if i > 0 && i % REPHASE_EVERY == 0 {
            // A new phase against the peer's own clock (a service's 2 ms tick, a device's
            // 1 ms loop): the grid moves by a uniformly random part of REPHASE_SPAN, so over
            // a run the echoed commands' waits integrate over every phase and the medians of
            // different runs compare (issue #30); a fixed grid keeps one phase a whole run.
            anchor += REPHASE_SPAN.mul_f64(uniform());
        }
        let deadline = anchor + period * i as u32 + period.mul_f64(uniform());
        let now = Instant::now();
        if deadline > now {
            std::thread::sleep(deadline - now);
        } else if now - deadline > period {
            // Woke a period late (a loaded machine): re-anchor rather than send a burst,
            // which would only measure latest-wins superseding.
            anchor = now - period * i as u32;
        }
        sent_at.push(Instant::now());
        writer.write(make(base + i as u32))?;
        i += 1;
        if i >= warmup + samples && i % 50 == 0 {
            let got = recv.lock().unwrap_or_else(|e| e.into_inner())[warmup..i]
                .iter()
                .filter(|x| x.is_some())
                .count();
            if got >= samples {
                break;
            }
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    let cpu_pct = pids
        .iter()
        .zip(&c0)
        .map(|(&p, c0)| 100.0 * (cpu_seconds(p).unwrap_or(f64::NAN) - c0) / wall)
        .collect();
    // Let the last answers arrive (a late one only adds a sample; nothing waits on it).
    let settle = Instant::now() + Duration::from_millis(300);
    while Instant::now() < settle {
        if recv.lock().unwrap_or_else(|e| e.into_inner())[i - 1].is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    drop(reader);
    let g = recv.lock().unwrap_or_else(|e| e.into_inner());
    let latency_us: Vec<f64> = (warmup..i)
        .filter_map(|k| g[k].map(|r| r.saturating_duration_since(sent_at[k]).as_secs_f64() * 1e6))
        .collect();
    Ok(TaggedRun {
        sent: i - warmup,
        latency_us,
        cpu_pct,
    })
}

/// One emulated Dex3 USB exchange, what the floor + exchange peer does per command: the
/// command frame built and encoded as the device loop does, exchanged with the MCU emulator
/// at the transport seam, the reply decoded into a measurement.
pub struct Exchange {
    transport: Box<dyn handgate_adapters::dex3::usb::Dex3Transport>,
    cfg: handgate_adapters::dex3::usb::LoopConfig,
    meas: handgate_adapters::dex3::Dex3Measurement,
    cmd_buf: [u8; handgate_adapters::dex3::usb::CMD_FRAME_LEN],
    st_buf: [u8; handgate_adapters::dex3::usb::STATE_FRAME_LEN],
}

impl Exchange {
    /// A left hand whose emulated time follows the wall clock (the hop's floor + exchange).
    pub fn new() -> anyhow::Result<Self> {
        use handgate_adapters::dex3::usb::{EmulatorClock, EmulatorConfig};
        Self::with(
            handgate_adapters::dex3::Side::Left,
            EmulatorConfig {
                clock: EmulatorClock::Wall,
                ..EmulatorConfig::default()
            },
        )
    }

    /// A `side` hand emulated with `config`.
    pub fn with(
        side: handgate_adapters::dex3::Side,
        config: handgate_adapters::dex3::usb::EmulatorConfig,
    ) -> anyhow::Result<Self> {
        use handgate_adapters::dex3::usb::{Dex3Emulator, EmulatorTransport};
        let emu = Arc::new(Mutex::new(Dex3Emulator::new(side, config)));
        Ok(Self {
            transport: EmulatorTransport::factory(emu)()?,
            cfg: handgate_adapters::dex3::usb::LoopConfig::default(),
            meas: handgate_adapters::dex3::Dex3Measurement::empty(Instant::now()),
            cmd_buf: [0; handgate_adapters::dex3::usb::CMD_FRAME_LEN],
            st_buf: [0; handgate_adapters::dex3::usb::STATE_FRAME_LEN],
        })
    }

    /// Sends `c` (positions and gains of its 7 motors) in one exchange.
    pub fn run(&mut self, c: &HandCmd_) -> anyhow::Result<()> {
        let mut cmd = handgate_adapters::dex3::Dex3Command::default();
        for (m, w) in cmd.motors.iter_mut().zip(&c.motor_cmd) {
            m.q = w.q;
            m.kp = w.kp;
            m.kd = w.kd;
        }
        self.send(&cmd).map(|_| ())
    }

    /// Sends `cmd` in one exchange: the command frame built and encoded, exchanged with the
    /// emulator, the reply decoded into the measurement returned.
    pub fn send(
        &mut self,
        cmd: &handgate_adapters::dex3::Dex3Command,
    ) -> anyhow::Result<&handgate_adapters::dex3::Dex3Measurement> {
        use handgate_adapters::dex3::usb::codec::McuToLinuxState;
        use handgate_adapters::dex3::usb::convert::{apply_state, build_command};
        build_command(cmd, &self.cfg.wiring, &self.cfg.scalings, true).encode_into(&mut self.cmd_buf);
        self.transport
            .exchange(&self.cmd_buf, &mut self.st_buf, self.cfg.exchange_timeout)?;
        let st = McuToLinuxState::decode(&self.st_buf)?;
        apply_state(&mut self.meas, &st, &self.cfg.wiring, &self.cfg.scalings);
        Ok(&self.meas)
    }
}

/// The floor: answers every HandCmd_ at once, from the DDS listener thread, with a HandState_
/// of 7 motors and 9 pads echoing `reserve[0]`. With `exchange`, each command first goes
/// through one emulated Dex3 USB exchange ([`Exchange`]): the least a gateway in front of a
/// USB hand must do. With `tick`, an ideal gateway in front of a device polled at that period
/// instead: the newest tag is answered at the next tick of its own clock (no device, no work:
/// only the wait for the next cycle). With `exchange` and `threaded`, the exchange and the
/// answer run on a thread of their own, which the listener hands each command to (park /
/// unpark): the least a gateway can do that keeps a USB hand's exchanges off the DDS
/// listener (a real USB transfer blocks for its round trip), one thread hand-off more than
/// `exchange`. Runs until killed.
pub fn echo(
    domain: u32,
    iface: Option<&str>,
    cmd_topic: &str,
    state_topic: &str,
    tick: Option<Duration>,
    exchange: bool,
    threaded: bool,
) -> anyhow::Result<()> {
    let node = Node::new(domain, iface)?;
    let mut writer = node.writer::<HandState_>(state_topic, Qos::BestEffort)?;
    let answer = |w: &mut handgate_adapters::dds::Writer<HandState_>, tag: u32| {
        let mut s = HandState_::with_sizes(DEX3_MOTORS, DEX3_PRESS_SENSORS);
        s.reserve[0] = tag;
        let _ = w.write(s);
    };
    if threaded {
        let mut ex = Exchange::new()?;
        let slot: Arc<Mutex<Option<HandCmd_>>> = Arc::default();
        let s2 = slot.clone();
        let worker = std::thread::Builder::new()
            .name("echo-exchange".into())
            .spawn(move || loop {
                std::thread::park();
                while let Some(c) = s2.lock().unwrap_or_else(|e| e.into_inner()).take() {
                    if let Err(e) = ex.run(&c) {
                        eprintln!("echo: exchange failed: {e}");
                    }
                    answer(&mut writer, c.reserve[0]);
                }
            })?;
        let waker = worker.thread().clone();
        let _reader = node.reader_with_callback::<HandCmd_, _>(cmd_topic, Qos::Reliable { depth: 16 }, move |h| {
            let mut v = Vec::new();
            h.take_into(&mut v);
            if let Some(c) = v.pop() {
                *slot.lock().unwrap_or_else(|e| e.into_inner()) = Some(c);
                waker.unpark();
            }
        })?;
        println!("READY");
        loop {
            std::thread::park();
        }
    }
    let mut ex = if exchange { Some(Exchange::new()?) } else { None };
    let pending: Arc<Mutex<Option<u32>>> = Arc::default();
    let p = pending.clone();
    let (mut direct, ticked) = match tick {
        None => (Some(writer), None),
        Some(_) => (None, Some(writer)),
    };
    let _reader = node.reader_with_callback::<HandCmd_, _>(cmd_topic, Qos::Reliable { depth: 16 }, move |h| {
        let mut v = Vec::new();
        h.take_into(&mut v);
        for c in v {
            if let Some(ex) = ex.as_mut() {
                if let Err(e) = ex.run(&c) {
                    eprintln!("echo: exchange failed: {e}");
                }
            }
            match direct.as_mut() {
                Some(w) => answer(w, c.reserve[0]),
                None => *p.lock().unwrap_or_else(|e| e.into_inner()) = Some(c.reserve[0]),
            }
        }
    })?;
    println!("READY");
    let (Some(tick), Some(mut writer)) = (tick, ticked) else {
        loop {
            std::thread::park();
        }
    };
    let t0 = Instant::now();
    let mut k: u32 = 0;
    loop {
        k = k.wrapping_add(1);
        let next = t0 + tick * k;
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        }
        let tag = pending.lock().unwrap_or_else(|e| e.into_inner()).take();
        if let Some(tag) = tag {
            answer(&mut writer, tag);
        }
    }
}
