//! No heap allocation in a device loop's steady-state cycle (issue #26; the idea of
//! ros2_control's `hardware_interface_testing/test/test_rt_allocation.cpp`).
//!
//! This test binary installs a counting global allocator (only here: an integration test is
//! its own binary, so the library and every other test keep the plain system allocator). It
//! counts per thread, and each test reads the counters of one device-loop thread only, over
//! several hundred steady-state cycles after a warm-up: a client streams commands (each one
//! sent once the state shows the previous one reflected), the loop measures and publishes
//! state. Allocations on other threads (the client, CycloneDDS's threads, the emulators) are
//! not the loop's and are not counted.
//!
//! What is counted is Rust's global allocator: malloc calls made inside C libraries
//! (CycloneDDS, libusb) are not seen (docs/deployment.md, "Real-time").
//!
//! A DDS-client device's writes go through cyclonedds-rs, which allocates per sample; those
//! allocations ([`handgate_adapters::dds::within`] tells them) are counted apart,
//! reported, and bounded per write; handgate's own part of the cycle must allocate nothing.
//! A DDS-client device does part of its work on the thread that brings it (a forwarded command
//! on the caller's, an awaited state sample in the reader's listener): that work is counted by
//! scope (`Within::Device`) on every thread, not by its loop thread alone.
//!
//! Counts are per cycle, never per second: a busy machine makes the window take longer, not
//! the counts differ. The timeouts below are generous so that a starved peer never sends a
//! loop down an error path (an error's text allocates; that is not the steady state).

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::control::Active;
use handgate_adapters::dds::Node;
use handgate_adapters::dds_device::{DdsCodec, DdsDevice, DdsDeviceConfig, Forwarding};
use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::mapping::{DeviceTable, TableOverrides};
use handgate_adapters::model::{CommandBody, DeviceKind, HandCommand, HandState, JointCommand, JointId, Side};

#[path = "support/counting.rs"]
mod counting;
use counting::{thread_named as thread_named_within, threads_where, Counts};

/// The kernel thread id of this process's thread named `name` (its `comm`).
fn thread_named(name: &str) -> i32 {
    thread_named_within(name, DEADLINE)
}

impl Counts {
    fn plus(self, o: Counts) -> Counts {
        Counts {
            allocs: self.allocs + o.allocs,
            bytes: self.bytes + o.bytes,
            frees: self.frees + o.frees,
            write_allocs: self.write_allocs + o.write_allocs,
            write_bytes: self.write_bytes + o.write_bytes,
            callback_allocs: self.callback_allocs + o.callback_allocs,
            callback_bytes: self.callback_bytes + o.callback_bytes,
            device_allocs: self.device_allocs + o.device_allocs,
            device_bytes: self.device_bytes + o.device_bytes,
        }
    }

    /// What a DDS-client device's task made, on every thread: all of `loop_tids`' (the threads
    /// that run device loops; outside the task's scope, the loop's scheduler), and the task's
    /// scope (`Within::Device`, and the writes made in it: `caller`, the one other thread that
    /// forwards commands) on every other thread.
    fn of_dds_task(loop_tids: &[i32], caller: i32) -> Self {
        let mut sum = Counts::default();
        for s in Self::slots() {
            let tid = s.tid.load(Relaxed);
            let c = Counts::load(s);
            if loop_tids.contains(&tid) {
                sum = sum.plus(c);
            } else {
                let (writes, write_bytes) = if tid == caller {
                    (c.write_allocs, c.write_bytes)
                } else {
                    (0, 0)
                };
                sum = sum.plus(Counts {
                    allocs: c.device_allocs + writes,
                    bytes: c.device_bytes + write_bytes,
                    write_allocs: writes,
                    write_bytes,
                    device_allocs: c.device_allocs,
                    device_bytes: c.device_bytes,
                    ..Counts::default()
                });
            }
        }
        sum
    }
}

// ---------------------------------------------------------------------------------------
// Measuring one loop.

/// Cycles run before counting: every buffer reaches its steady-state capacity.
const WARM_UP: u64 = 200;
/// Cycles counted.
const MEASURED: u64 = 500;
/// Bound on any wait for the loop (a starved machine only makes it slower).
const DEADLINE: Duration = Duration::from_secs(60);

/// Waits (polling) until `f` holds.
fn wait_for(what: &str, mut f: impl FnMut() -> bool) {
    let end = Instant::now() + DEADLINE;
    while !f() {
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_micros(200));
    }
}

/// What one loop thread allocated over a window of cycles.
#[derive(Debug)]
struct Window {
    cycles: u64,
    writes: u64,
    counts: Counts,
}

impl Window {
    /// Allocations of the loop's own code (everything but the DDS writes and the reader
    /// callbacks run inside them).
    fn own(&self) -> (u64, u64) {
        self.counts.own()
    }

    fn report(&self, name: &str) -> String {
        let per = |v: u64| v as f64 / self.cycles as f64;
        let (own, own_bytes) = self.own();
        let mut s = format!(
            "{name}: {} cycles: {own} allocations ({own_bytes} B) of its own = {:.2}/cycle ({:.1} B/cycle); {} frees = {:.2}/cycle",
            self.cycles,
            per(own),
            per(own_bytes),
            self.counts.frees,
            per(self.counts.frees),
        );
        let c = &self.counts;
        if self.writes > 0 || c.write_allocs + c.callback_allocs > 0 {
            let per_write = |v: u64| v as f64 / self.writes.max(1) as f64;
            s += &format!(
                "; {} DDS writes: the binding's {} allocations ({} B) = {:.2}/write ({:.1} B/write), \
                 in-process readers' callbacks inside them {} allocations ({} B) = {:.2}/write",
                self.writes,
                c.write_allocs,
                c.write_bytes,
                per_write(c.write_allocs),
                per_write(c.write_bytes),
                c.callback_allocs,
                c.callback_bytes,
                per_write(c.callback_allocs),
            );
        }
        s
    }
}

/// A client streaming joint commands toward alternating targets (the joint keeps moving),
/// each one once the state shows the previous one reflected.
struct Client<'a> {
    dev: &'a dyn HandDevice,
    joint: JointId,
    targets: [f32; 2],
    seq: u64,
}

impl<'a> Client<'a> {
    fn new(dev: &'a dyn HandDevice, joint: JointId, targets: [f32; 2]) -> Self {
        Self {
            dev,
            joint,
            targets,
            seq: 0,
        }
    }

    /// Sends the next command and waits until the device's state reflects it.
    fn step(&mut self) {
        self.seq += 1;
        let q = self.targets[self.seq as usize % 2];
        self.dev
            .command(HandCommand {
                seq: self.seq,
                body: CommandBody::Joints(vec![(self.joint, JointCommand::hold(q, 1.5, 0.1))]),
                tag: self.seq as u32,
            })
            .unwrap();
        let rx = self.dev.state();
        wait_for("the state to reflect the command", || rx.borrow().cmd_seq >= self.seq);
    }
}

/// Streams commands from `client` and counts what `counts` reads (one loop's threads) over
/// [`MEASURED`] cycles after [`WARM_UP`]; `progress` reads the loop's (cycles, DDS writes).
fn measure(counts: impl Fn() -> Counts, progress: impl Fn() -> (u64, u64), client: &mut Client) -> Window {
    let (c, _) = progress();
    while progress().0 < c + WARM_UP {
        client.step();
    }
    let (c0, w0) = progress();
    let a0 = counts();
    while progress().0 < c0 + MEASURED {
        client.step();
    }
    let a1 = counts();
    let (c1, w1) = progress();
    Window {
        cycles: c1 - c0,
        writes: w1 - w0,
        counts: a1.since(a0),
    }
}

fn assert_no_own_allocations(name: &str, w: &Window) {
    println!("{}", w.report(name));
    let (own, bytes) = w.own();
    assert_eq!(
        own,
        0,
        "{name} made {own} heap allocations ({bytes} B) of its own over {} steady-state cycles: a device loop's \
         cycle must not touch the heap (docs/deployment.md, \"Real-time\"). {}",
        w.cycles,
        w.report(name)
    );
}

fn info(name: &str, kind: DeviceKind, backend: Backend) -> DeviceInfo {
    DeviceInfo {
        name: name.into(),
        kind,
        side: Side::Left,
        backend,
        table: Arc::new(kind.table(Side::Left, &TableOverrides::default()).unwrap()),
    }
}

fn socket_path(what: &str) -> PathBuf {
    std::env::temp_dir().join(format!("handgate-rt-alloc-{what}-{}", std::process::id()))
}

/// Installs a tracing subscriber like the gateway's (fmt, `info`), writing nowhere: the
/// loops' spans and events go through a real subscriber, as they do in the gateway.
fn tracing_like_the_gateway() {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::new("info"))
        .with_writer(std::io::sink)
        .try_init();
}

// ---------------------------------------------------------------------------------------
// The loops.

/// The Dex3-1 USB loop (`dex3-usb-loop`): one frame exchange a cycle over the Unix-socket
/// transport to the emulated hand (the emulator serves on its own thread, as the hand's MCU
/// would), plus the adapter's observer turning each measurement into canonical state.
#[test]
fn the_dex3_usb_loop_allocates_nothing_per_cycle() {
    use handgate_adapters::dex3::usb::adapter::{Dex3UsbDevice, UsbSource};
    use handgate_adapters::dex3::usb::{EmulatorClock, EmulatorConfig, EmulatorServer, LoopConfig};

    tracing_like_the_gateway();
    let path = socket_path("dex3");
    let emu = EmulatorConfig {
        clock: EmulatorClock::Wall,
        ..EmulatorConfig::default()
    };
    let _server = EmulatorServer::spawn(&path, Side::Left, emu).unwrap();
    let config = LoopConfig {
        // An emulated hand: no spinning (as `open` sets it), and no timeout a starved
        // emulator thread could cause.
        spin: Duration::ZERO,
        exchange_timeout: Duration::from_secs(5),
        ..LoopConfig::default()
    };
    let dev = Dex3UsbDevice::start(
        info("hand", DeviceKind::Dex3, Backend::Usb),
        UsbSource::Socket(path),
        config,
    )
    .unwrap();
    let rx = dev.state();
    wait_for("the first measured state", || rx.borrow().measured_at.is_some());
    let tid = thread_named("dex3-usb-loop");
    let joint = dev.info().table.joint_by_name("index_0").unwrap();
    let w = measure(
        || Counts::of(tid),
        || (dev.stats().cycles, 0),
        &mut Client::new(&dev, joint, [0.2, 0.6]),
    );
    dev.stop();
    assert_no_own_allocations("dex3-usb-loop", &w);
}

/// Counts the commands encoded on thread `caller` (the client's: forwarded at once, not by
/// the loop).
struct Probe<C> {
    codec: C,
    caller: i32,
    inline: Arc<AtomicU64>,
}

impl<C: DdsCodec> DdsCodec for Probe<C> {
    type Cmd = C::Cmd;
    type State = C::State;

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, dt: f32, msg: &mut Self::Cmd) -> bool {
        // SAFETY: gettid has no preconditions.
        if unsafe { libc::gettid() } == self.caller {
            self.inline.fetch_add(1, Relaxed);
        }
        self.codec.encode_into(active, table, dt, msg)
    }

    fn decode_into(&mut self, sample: &Self::State, table: &DeviceTable, st: &mut HandState) -> bool {
        self.codec.decode_into(sample, table, st)
    }
}

/// The Dex1-1 client (`unitree_go` MotorCmds_ / MotorStates_) at 500 Hz against the emulated
/// Dex1-1 service.
#[test]
fn a_dds_client_device_task_allocates_nothing_of_its_own_per_cycle() {
    use handgate_adapters::dex1::adapter::{Dex1GoCodec, Variant};
    use handgate_adapters::dex1::emulator::{Dex1Config, Dex1Emulator};

    tracing_like_the_gateway();
    let node = Node::new(57, None).unwrap();
    let _emu = Dex1Emulator::start(&node, Dex1Config::new(Variant::Go, Side::Left)).unwrap();
    // SAFETY: gettid has no preconditions.
    let caller = unsafe { libc::gettid() };
    let inline = Arc::new(AtomicU64::new(0));
    let rate = 500.0;
    let dev = DdsDevice::start(
        &node,
        info("dex1", DeviceKind::Dex1, Backend::Dds),
        DdsDeviceConfig {
            cmd_topic: "rt/dex1/left/cmd".into(),
            state_topic: Some("rt/dex1/left/state".into()),
            rate_hz: rate,
            // Never stale on a starved machine (a link-down spell is not the steady state).
            stale_after: Duration::from_secs(5),
            forward: Forwarding::default_for(rate),
        },
        Probe {
            codec: Dex1GoCodec::new(Variant::Go, Side::Left),
            caller,
            inline: inline.clone(),
        },
    )
    .unwrap();
    let rx = dev.state();
    wait_for("the first measured state", || rx.borrow().measured_at.is_some());
    let mut client = Client::new(&dev, JointId(0), [1.0, 4.0]);
    // The device loops' threads (crate::loops's shared pool; no other loop of this binary
    // runs there).
    let loop_tids = threads_where(|comm| comm.starts_with("dev-shared-"));
    assert!(!loop_tids.is_empty(), "no device-loop thread");
    let progress = || {
        let s = dev.stats();
        (s.cycles, s.sent)
    };
    let inline0 = inline.load(Relaxed);
    let w = measure(|| Counts::of_dds_task(&loop_tids, caller), progress, &mut client);
    let inline = inline.load(Relaxed) - inline0;
    dev.stop();
    println!("{inline} commands of the warm-up and the window were encoded and written on the client's thread");
    assert_no_own_allocations("dds-client task (dex1)", &w);
    // The run took commands on their own thread, not only on the loop's.
    assert!(
        inline > 0,
        "no command was forwarded on the client's thread: {}",
        w.report("dds-client task (dex1)")
    );
    // The binding's part, bounded by what was measured: per sample, the copy its owned
    // `Arc<T>` API needs (the sample's sequence and the Arc), cyclonedds-rs's SerData of the
    // sample and the untyped one CycloneDDS's key map asks for, and five for the delivery to
    // the in-process service's reader (serialise, SerData, iovec list, deserialised sequence,
    // Arc): 9 (docs/deployment.md, "Real-time"). A write at each end of the window may be
    // half in it.
    assert!(
        w.counts.write_allocs <= (w.writes + 2) * BINDING_ALLOCS_PER_WRITE,
        "the binding allocated more per write than measured: {}",
        w.report("dds-client task (dex1)")
    );
    assert_eq!(
        w.counts.callback_allocs, 0,
        "no in-process reader listens to the command topic"
    );
}

/// What one `Writer::write_copy` of a Dex1 command allocates inside cyclonedds-rs, measured
/// (see the test above).
const BINDING_ALLOCS_PER_WRITE: u64 = 9;

/// The EZGripper bus round (`ezgripper-bus`: sync-write the goals, sync-read the present
/// values, publish) over the real serial transport, to the emulated servo behind a pty (its
/// own thread); and the gripper's bridge (`ezgripper-<device>`) turning each round's
/// measurement into canonical state.
#[test]
fn the_ezgripper_bus_round_and_bridge_allocate_nothing_per_cycle() {
    use handgate_adapters::ezgripper::adapter::EzGripperDevice;
    use handgate_adapters::ezgripper::emulator::{EmulatorConfig, VirtualBus};
    use handgate_adapters::ezgripper::{BusConfig, EzError, EzGripperBus, GripperConfig, ServoId};

    tracing_like_the_gateway();
    let path = socket_path("ezgripper");
    let _emu = VirtualBus::start(&path, EmulatorConfig::with_ids(&[1])).unwrap();
    let id = ServoId::new(1).unwrap();
    let cfg = BusConfig {
        grippers: vec![GripperConfig {
            id,
            zero_ticks: Some(1000),
        }],
        calibrate_on_start: false,
        // A starved emulator thread must not make a reply miss its deadline.
        response_timeout_ms: 5000,
        stale_after_ms: 5000,
        ..Default::default()
    };
    let bus = (0..5)
        .find_map(|_| match EzGripperBus::open(&path, cfg.clone()) {
            Ok(b) => Some(b),
            Err(EzError::NoAnswer { .. }) => None,
            Err(e) => panic!("open: {e}"),
        })
        .expect("the bus opens");
    let bus = Arc::new(bus);
    let dev = EzGripperDevice::start(info("g", DeviceKind::Ezgripper, Backend::Serial), bus.clone(), id, 50.0).unwrap();
    let rx = dev.state();
    wait_for("the first measured state", || rx.borrow().measured_at.is_some());
    let (bus_tid, bridge_tid) = (thread_named("ezgripper-bus"), thread_named("ezgripper-g"));
    let mut client = Client::new(&dev, JointId(0), [1.0, 4.0]);
    // The bus round: its rounds are its cycles.
    let w = measure(|| Counts::of(bus_tid), || (bus.stats().rounds, 0), &mut client);
    let bridge = measure(|| Counts::of(bridge_tid), || (dev.stats().cycles, 0), &mut client);
    dev.stop();
    assert_no_own_allocations("ezgripper-bus", &w);
    assert_no_own_allocations("ezgripper bridge", &bridge);
}

/// The Robotiq device loop (`robotiq-<device>`): one FC23 exchange a cycle through the Modbus
/// kit's RTU master on a pseudo-terminal, to an emulated gripper served by the stream server
/// (its own thread, as the gripper's controller would be), then the status made canonical.
#[test]
fn the_robotiq_device_loop_allocates_nothing_per_cycle() {
    use std::sync::Mutex;

    use handgate_adapters::front::serve::{Inbox, Queue};
    use handgate_adapters::front::stream::serve_pty;
    use handgate_adapters::modbus::master::RtuTiming;
    use handgate_adapters::robotiq::device::{LoopConfig, RobotiqDevice};
    use handgate_adapters::robotiq::emulator::{Gripper, Tuning};
    use handgate_adapters::robotiq::front::rtu_session_on;
    use handgate_adapters::robotiq::rtu::RtuLink;
    use handgate_adapters::robotiq::Variant;
    use handgate_adapters::serial::transport::SerialConnector;

    tracing_like_the_gateway();
    let path = socket_path("robotiq");
    let tuning = Tuning {
        activation: Duration::from_millis(100),
        ..Tuning::default()
    };
    let g = Arc::new(Mutex::new(Gripper::new(
        Variant::TwoF85.spec(),
        tuning,
        0.0,
        None,
        Instant::now(),
    )));
    let (tx, _rx) = tokio::sync::mpsc::channel(1);
    let _emu = serve_pty(
        &path,
        move || rtu_session_on(g.clone(), 9),
        Inbox::for_tests(Queue::new(tx)),
        "rt-alloc",
        "robotiq emulator",
    )
    .unwrap();
    let timing = RtuTiming {
        // A starved emulator thread must not make an answer miss its deadline.
        response_timeout: Duration::from_secs(5),
        ..RtuTiming::serial(115_200)
    };
    let connector = SerialConnector {
        path: path.clone(),
        baud: 115_200,
    };
    let link = RtuLink::open(Box::new(connector), timing, 9).unwrap();
    let cfg = LoopConfig {
        rate_hz: 200.0,
        stale_after: Duration::from_secs(5),
        speed: 255,
        force: 100,
    };
    let dev = RobotiqDevice::start(info("g", DeviceKind::Robotiq, Backend::Serial), Box::new(link), cfg).unwrap();
    let rx = dev.state();
    // gSTA 3 in the status byte the state carries as its mode.
    wait_for("the gripper activated", || (rx.borrow().mode >> 4) & 3 == 3);
    let tid = thread_named("robotiq-g");
    let mut client = Client::new(&dev, JointId(0), [0.2, 0.6]);
    let w = measure(|| Counts::of(tid), || (dev.stats().cycles, 0), &mut client);
    dev.stop();
    assert_no_own_allocations("robotiq device loop", &w);
}

/// The Inspire RH56 line's round (`rh56-line`: an ANGLE_SET write when the target changed,
/// the ANGLE_ACT read, the slow block, one tactile batch; the serial protocol over the real
/// serial transport to two emulated DFTPs behind a pty) and a hand's bridge (`rh56-<device>`)
/// turning each reading (its 1062 tactile cells included) into canonical state and pads.
#[test]
fn the_inspire_rh56_line_round_and_bridge_allocate_nothing_per_cycle() {
    use handgate_adapters::inspire_rh56::adapter::Rh56Device;
    use handgate_adapters::inspire_rh56::bus::{BusConfig, Rh56Bus};
    use handgate_adapters::inspire_rh56::emulator::{HandSpec, Line, Rh56Hand};
    use handgate_adapters::inspire_rh56::pty::PtyLine;

    tracing_like_the_gateway();
    let path = socket_path("rh56");
    let dftp = |id| {
        let mut s = HandSpec::new(id);
        s.tactile = true;
        Rh56Hand::new(s)
    };
    let _emu = PtyLine::start(&path, Line::new(vec![dftp(1), dftp(2)])).unwrap();
    let cfg = BusConfig {
        ids: vec![1, 2],
        tactile: true,
        // A starved emulator thread must not make a reply miss its deadline.
        response_timeout: Duration::from_secs(5),
        stale_after: Duration::from_secs(5),
        ..Default::default()
    };
    let bus = Arc::new(Rh56Bus::open(path.to_str().unwrap(), cfg).unwrap());
    let dev = Rh56Device::start(
        info("g", DeviceKind::InspireRh56, Backend::Serial),
        bus.clone(),
        1,
        Duration::from_secs(5),
    )
    .unwrap();
    let rx = dev.state();
    wait_for("the first measured state with pads", || {
        let st = rx.borrow();
        st.measured_at.is_some() && st.pads.len() == 17
    });
    let (line_tid, bridge_tid) = (thread_named("rh56-line"), thread_named("rh56-g"));
    let mut client = Client::new(&dev, JointId(0), [0.3, 1.2]);
    let w = measure(|| Counts::of(line_tid), || (bus.stats().rounds, 0), &mut client);
    let bridge = measure(|| Counts::of(bridge_tid), || (dev.stats().cycles, 0), &mut client);
    dev.stop();
    assert_no_own_allocations("rh56-line", &w);
    assert_no_own_allocations("rh56 bridge", &bridge);
}

/// The LEAP Hand's device loop (`leap-<device>`: sync write of 16 goals, sync read of 16
/// present blocks, the canonical state published) over the real serial transport, to the
/// emulated hand behind a pty (its own thread).
#[test]
fn the_leap_device_loop_allocates_nothing_per_cycle() {
    use handgate_adapters::leap::device::{LeapBusConfig, LeapDevice};
    use handgate_adapters::leap::emulator::{EmulatorConfig, VirtualLeap};
    use handgate_adapters::serial::SerialConnector;

    tracing_like_the_gateway();
    let path = socket_path("leap");
    let _emu = VirtualLeap::start(
        &path,
        EmulatorConfig::with_ids(&handgate_adapters::leap::control_table::DEFAULT_IDS),
    )
    .unwrap();
    let cfg = LeapBusConfig {
        // A starved emulator thread must not make a reply miss its deadline.
        response_grace: Duration::from_secs(5),
        stale_after: Duration::from_secs(5),
        ..Default::default()
    };
    let connector = SerialConnector {
        path: path.clone(),
        baud: cfg.baud,
    };
    let dev = LeapDevice::start(info("l", DeviceKind::Leap, Backend::Serial), Box::new(connector), cfg).unwrap();
    let rx = dev.state();
    wait_for("the first measured state", || rx.borrow().measured_at.is_some());
    let tid = thread_named("leap-l");
    let mut client = Client::new(&dev, JointId(1), [0.3, 1.2]);
    let w = measure(|| Counts::of(tid), || (dev.stats().cycles, 0), &mut client);
    dev.stop();
    assert_no_own_allocations("leap", &w);
}

/// A register-mapped Modbus hand (the ROHand) over the kit's emulated RTU line: the line's
/// round (an FC16 when the target changed, an FC03 of 66 words, the emulator core answering
/// on the same thread at the wire's time) and the device's bridge allocate nothing.
#[test]
fn the_modbus_hand_line_round_and_bridge_allocate_nothing_per_cycle() {
    use std::sync::Mutex;

    use handgate_adapters::modbus::hand::device::ModbusHandDevice;
    use handgate_adapters::modbus::hand::emulated::EmulatedLine;
    use handgate_adapters::modbus::hand::line::{HandLine, LineConfig};
    use handgate_adapters::modbus::hand::{EmuSpec, RegisterHand};
    use handgate_adapters::rohand::{Rohand, FINGERS};

    tracing_like_the_gateway();
    let spec = EmuSpec {
        slave: 2,
        start: vec![0.0; FINGERS],
        object_at: vec![None; FINGERS],
    };
    let cores = Arc::new(Mutex::new(vec![(2u8, Rohand::core(&spec))]));
    let cfg = LineConfig {
        baud: 115_200,
        slaves: vec![2],
        // A starved thread must not make a reply miss its deadline.
        response_timeout: Duration::from_secs(5),
        period: None,
        state: Rohand::STATE,
        target: Rohand::TARGET,
        init: Rohand::INIT,
        over_tcp: false,
    };
    let line = Arc::new(HandLine::start(Box::new(EmulatedLine::new(cores, 115_200)), cfg).unwrap());
    let dev = ModbusHandDevice::<Rohand>::start(
        info("g", DeviceKind::Rohand, Backend::Emulator),
        line.clone(),
        2,
        Duration::from_secs(5),
    )
    .unwrap();
    let rx = dev.state();
    wait_for("the first measured state", || rx.borrow().measured_at.is_some());
    let (line_tid, bridge_tid) = (thread_named("mb-hand-line"), thread_named("rohand-g"));
    let mut client = Client::new(&dev, JointId(1), [0.3, 1.0]);
    let rounds = || line.counters.rounds.load(Relaxed);
    let w = measure(|| Counts::of(line_tid), || (rounds(), 0), &mut client);
    let bridge = measure(|| Counts::of(bridge_tid), || (dev.stats().cycles, 0), &mut client);
    dev.stop();
    assert_no_own_allocations("modbus hand line", &w);
    assert_no_own_allocations("modbus hand bridge", &bridge);
}

/// Every DDS-client kind's codec as the task calls it each cycle (`encode_into`,
/// `decode_into`, `commanded_state`, on the buffers the task keeps), on this thread: nothing
/// allocates once the buffers have grown. The task around them is measured above with the
/// Dex1 codec; these are the other kinds' parts of its cycle.
#[test]
fn every_dds_client_codec_fills_its_buffers_without_allocating() {
    use handgate_adapters::brainco::adapter::BraincoCodec;
    use handgate_adapters::dex1::adapter::{Dex1GoCodec, Dex1HgCodec, Variant};
    use handgate_adapters::dex3::dds_client::Dex3DdsCodec;
    use handgate_adapters::hand_sdk::adapter::{HandSdkCodec, WeightRamp};
    use handgate_adapters::inspire_dfx::adapter::DfxCodec;
    use handgate_adapters::inspire_ftp::adapter::{FtpClient, FtpCodec};
    use handgate_idl::inspire::{InspireHandState, InspireHandTouch};
    use handgate_idl::{unitree_go, unitree_hg};

    let go = |n| unitree_go::MotorStates_::with_len(n);
    let hg = |motors, pads| unitree_hg::HandState_::with_sizes(motors, pads);
    let ftp_state = InspireHandState::sdk_default();
    let dex1_go = |variant| Dex1GoCodec::new(variant, Side::Left);
    check_stateful("dex1 go", DeviceKind::Dex1, dex1_go(Variant::Go), &go(1));
    check_stateful("dex1 actuator", DeviceKind::Dex1, dex1_go(Variant::Actuator), &go(2));
    check_stateful("dex1 hg", DeviceKind::Dex1, Dex1HgCodec, &hg(1, 0));
    check_stateful("dex3 dds", DeviceKind::Dex3, Dex3DdsCodec::default(), &hg(7, 9));
    check_stateful("brainco", DeviceKind::Brainco, BraincoCodec::default(), &go(6));
    check_stateful(
        "inspire_dfx",
        DeviceKind::InspireDfx,
        DfxCodec::new(Side::Left).unwrap(),
        &go(12),
    );
    check_stateful("inspire_ftp", DeviceKind::InspireFtp, FtpCodec::default(), &ftp_state);
    // No feedback: the commanded state instead of a decoded one.
    let hand_sdk = HandSdkCodec::new(WeightRamp::default());
    check("hand_sdk", DeviceKind::HandSdk, hand_sdk, &go(4), false, || 0);
    // The Inspire FTP client over Modbus TCP: a touch sample arrives before every state.
    // Written on this thread, CycloneDDS runs the client's touch reader here, inside the
    // write: both are counted apart (`dds::Within`), the codec's decode is what is asserted.
    let node = Node::new(58, None).unwrap();
    let topic = "rt/handgate/rt_alloc/touch";
    let client = FtpClient::new(&node, FtpCodec::default(), Some(topic)).unwrap();
    let mut touch = node
        .writer::<InspireHandTouch>(topic, handgate_adapters::dds_device::STATE_QOS)
        .unwrap();
    let sample = InspireHandTouch::sdk_default();
    check(
        "inspire_ftp + touch",
        DeviceKind::InspireFtp,
        client,
        &ftp_state,
        true,
        || {
            touch.write_copy(&sample).unwrap();
            1
        },
    );
}

/// [`check`] a codec that decodes `sample`, with nothing arriving between the cycles.
fn check_stateful<C: DdsCodec>(name: &str, kind: DeviceKind, codec: C, sample: &C::State) {
    check(name, kind, codec, sample, true, || 0);
}

/// Calls `codec` as the task does, [`MEASURED`] times after [`WARM_UP`], and asserts that
/// none of it allocated on this thread (`between` runs before each call: a sample arriving;
/// it returns the DDS writes it made).
fn check<C: DdsCodec>(
    name: &str,
    kind: DeviceKind,
    mut codec: C,
    sample: &C::State,
    has_state: bool,
    mut between: impl FnMut() -> u64,
) {
    let table = kind.table(Side::Left, &TableOverrides::default()).unwrap();
    // Targets that move every cycle, built before counting.
    let targets = [0.2, 0.8].map(|c| Active::Command(table.closure_targets(c, None).unwrap()));
    let (mut msg, mut st) = (C::Cmd::default(), HandState::default());
    // One cycle; the DDS writes `between` made.
    let mut cycle = |i: u64| {
        let writes = between();
        if has_state {
            assert!(
                codec.decode_into(sample, &table, &mut st),
                "{name}: the sample is this device's"
            );
        } else {
            codec.commanded_state(&table, &mut st);
        }
        assert!(
            codec.encode_into(&targets[i as usize % 2], &table, 0.002, &mut msg),
            "{name}: a message for the targets"
        );
        writes
    };
    for i in 0..WARM_UP {
        cycle(i);
    }
    // SAFETY: gettid has no preconditions.
    let tid = unsafe { libc::gettid() };
    let before = Counts::of(tid);
    let writes = (0..MEASURED).map(&mut cycle).sum();
    let w = Window {
        cycles: MEASURED,
        writes,
        counts: Counts::of(tid).since(before),
    };
    assert_no_own_allocations(&format!("{name} codec"), &w);
}
