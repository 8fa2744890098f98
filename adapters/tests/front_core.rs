//! The front core as a program using handgate_adapters as a library runs it, without the
//! gateway: one front over a Dex3 hand's in-process USB emulator (the device loop and the MCU
//! emulator of `Dex3UsbDevice`), the strict watchdog. A command reaches the hand; when its
//! client falls silent, the core's deadline moves the hand to its safe action (limp: the hand
//! is sent zero gains, its state carries the safe-state fault); the next command resumes.
//! Every wait polls a condition with a deadline.

use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::WriterInfo;
use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::dex3::usb::adapter::{Dex3UsbDevice, UsbSource};
use handgate_adapters::dex3::usb::emulator::lock;
use handgate_adapters::dex3::usb::LoopConfig;
use handgate_adapters::dex3::{Joint, Side};
use handgate_adapters::front::config::{Control, Silence};
use handgate_adapters::front::core::{Action, Counter, Devices, Driven, FrontCore, FrontId, Log, OwnDevices, Sample};
use handgate_adapters::front::plan::SilencePlan;
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{faults, CommandBody, DeviceKind, Freshness, HandState, JointCommand, SafeAction};
use handgate_adapters::route::Route;

mod common;
use common::wait_for;

const DEADLINE: Duration = Duration::from_secs(20);
const WATCHDOG: Duration = Duration::from_millis(200);

/// What the program does with the core's actions: runs a silence action to completion (a
/// program with deadlines to keep would spawn it, and wait for it before the device's next
/// command), counts, and keeps the log lines and publishes for the test to read.
#[derive(Default)]
struct Done {
    accepted: u64,
    trips: u64,
    safe: Vec<SafeAction>,
    publishes: u64,
    logs: Vec<Log>,
}

fn carry_out(acts: &mut Vec<Action>, devices: &OwnDevices, rt: &tokio::runtime::Runtime, done: &mut Done) {
    for a in acts.drain(..) {
        match a {
            Action::Count { counter, .. } => match counter {
                Counter::Accepted => done.accepted += 1,
                Counter::WatchdogTrip => done.trips += 1,
                Counter::Rejected | Counter::ForeignCmd | Counter::Duplicate | Counter::Reordered | Counter::Late => {}
            },
            Action::Publish => done.publishes += 1,
            Action::Safe { device, action } => {
                rt.block_on(devices.device(device).safe_state(action))
                    .expect("safe state");
                done.safe.push(action);
            }
            Action::Owner { .. } => {}
            Action::Log(l) => done.logs.push(l),
        }
    }
}

#[test]
fn a_library_front_core_moves_a_silent_clients_device_to_its_safe_action() {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .unwrap();
    let table = Arc::new(DeviceKind::Dex3.table(Side::Left, &TableOverrides::default()).unwrap());
    let info = DeviceInfo {
        name: "hand".into(),
        kind: DeviceKind::Dex3,
        side: Side::Left,
        backend: Backend::Emulator,
        table: table.clone(),
    };
    let dev = Arc::new(
        Dex3UsbDevice::start(info, UsbSource::Emulator(Box::default()), LoopConfig::default()).expect("device starts"),
    );
    let emu = dev.emulator.clone().expect("in-process emulator");
    let state = dev.state();
    let st = || -> HandState { state.borrow().clone() };
    wait_for(DEADLINE, "the link up", || {
        (st().freshness == Freshness::Fresh).then_some(())
    });

    let mut devices = OwnDevices::new(vec![dev.clone() as Arc<dyn HandDevice>]);
    let silence = SilencePlan::keeps_last_target(Silence::Watchdog, (WATCHDOG, SafeAction::Limp));
    let mut core = FrontCore::new(
        FrontId::next(),
        Control::Exclusive,
        WATCHDOG,
        vec![Driven {
            route: Route::bind(table.clone(), table.clone()),
            silence,
        }],
    );
    let client = Arc::new(WriterInfo {
        handle: 1,
        label: Some("test client".into()),
        ..WriterInfo::default()
    });
    let index_0 = table.joint_by_name("index_0").unwrap();
    let mut acts = Vec::new();
    let mut done = Done::default();

    // A command sample: admitted, decoded (here: built as the codec would), checked, sent.
    let command =
        |core: &mut FrontCore, devices: &mut OwnDevices, acts: &mut Vec<Action>, done: &mut Done, q: f32, tag: u32| {
            let sample = Sample {
                writer: &client,
                force: false,
                taken: Instant::now(),
                stamp: None,
            };
            let admitted = core.admit(&sample, acts).expect("the only writer is admitted");
            let body = CommandBody::Joints(vec![(index_0, JointCommand::hold(q, 1.5, 0.1))]);
            core.decoded(
                admitted,
                Instant::now(),
                &sample,
                Ok(vec![(0, (body, tag, false))]),
                devices,
                acts,
            );
            carry_out(acts, devices, &rt, done);
        };
    command(&mut core, &mut devices, &mut acts, &mut done, 0.6, 7);
    assert_eq!(done.accepted, 1);
    // The state reflecting it: the core asks for a prompt publish.
    let seq = wait_for(DEADLINE, "the command applied", || {
        let s = st();
        (s.cmd_seq >= 1 && s.cmd_tag == 7).then_some(s.cmd_seq)
    });
    assert!(core.awaiting(0));
    core.state(Instant::now(), 0, seq, &mut acts);
    carry_out(&mut acts, &devices, &rt, &mut done);
    assert_eq!(done.publishes, 1);
    let sent = lock(&emu)
        .last_command(Joint::Index0)
        .expect("the hand was sent a command");
    assert!(sent.kp > 0.0, "{sent:?}");

    // The client falls silent: sleep until each deadline the core names, then let it act.
    let silent_from = Instant::now();
    while done.safe.is_empty() {
        let due = core.next_deadline().expect("the watchdog is armed");
        assert!(due <= silent_from + WATCHDOG, "armed from the command");
        std::thread::sleep(due.saturating_duration_since(Instant::now()));
        core.deadline(Instant::now(), &mut devices, &mut acts);
        carry_out(&mut acts, &devices, &rt, &mut done);
    }
    assert_eq!(done.safe, vec![SafeAction::Limp]);
    assert_eq!(done.trips, 1);
    assert!(devices.tripped(0));
    assert!(
        done.logs.iter().any(|l| matches!(
            l,
            Log::Silence {
                action: SafeAction::Limp,
                ..
            }
        )),
        "{:?}",
        done.logs
    );
    assert_eq!(core.next_deadline(), None, "once per silence");
    // The hand is limp: every joint sent zero gains, and its state says so.
    wait_for(DEADLINE, "the hand sent zero gains", || {
        let g = lock(&emu);
        Joint::ALL
            .iter()
            .all(|j| g.last_command(*j).is_some_and(|c| c.kp == 0.0 && c.kd == 0.0))
            .then_some(())
    });
    wait_for(DEADLINE, "the safe-state fault", || {
        (st().faults & faults::SAFE_STATE != 0).then_some(())
    });

    // The next command resumes: logged, the hand commanded again, the fault gone.
    command(&mut core, &mut devices, &mut acts, &mut done, 0.3, 8);
    assert!(
        done.logs.iter().any(|l| matches!(l, Log::Resumed { device: 0 })),
        "{:?}",
        done.logs
    );
    assert!(!devices.tripped(0));
    assert!(devices.is_last_front(0, core.id()));
    wait_for(DEADLINE, "commanded again", || {
        let s = st();
        (s.cmd_tag == 8 && s.faults & faults::SAFE_STATE == 0).then_some(())
    });
    let sent = lock(&emu).last_command(Joint::Index0).unwrap();
    assert!(sent.kp > 0.0, "{sent:?}");
}
