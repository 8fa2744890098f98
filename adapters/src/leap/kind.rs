//! The LEAP Hand v1 as a registered device kind: its facts, table, and how a hand opens (its
//! U2D2's port on backend serial, the in-process emulator on backend emulator) and emulates
//! (`handgate emulate leap`: a pseudo-terminal).

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use super::config::{LeapConfig, LeapProfile, Variant};
use super::device::{LeapBusConfig, LeapDevice};
use super::emulator::{EmulatorConfig, LeapEmulator, VirtualLeap, XC330_NOISE};
use super::table::{JOINTS, WIRE_OFFSET};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    DeviceKind, EmulateArgs, EmulateOption, EmulateOptions, Emulation, Kind, KindFacts, Rates, SectionSpec, Sides,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};
use crate::serial::transport::{Connector, SerialConnector};

impl DeviceKind {
    /// LEAP Hand v1 (16 Dynamixel XC330 on one bus).
    #[allow(non_upper_case_globals)]
    pub const Leap: DeviceKind = DeviceKind::of(&LeapKind);
}

/// The LEAP Hand v1.
#[derive(Debug, Clone, Copy)]
pub struct LeapKind;

/// The device loop's rate when the profile sets none (the 500 Hz; docs/leap.md).
pub const DEFAULT_RATE_HZ: f64 = 500.0;

impl Kind for LeapKind {
    const FACTS: KindFacts = KindFacts {
        sections: &[SectionSpec {
            key: "leap",
            backends: &[Backend::Serial, Backend::Emulator],
        }],
        sides: Sides::LeftOrRight { note: "" },
        fronts: &[crate::front::kind::FrontKind::LeapBus],
        ..KindFacts::new(
            "leap",
            &JOINTS,
            &[Backend::Serial, Backend::Emulator],
            Rates::fixed(DEFAULT_RATE_HZ),
        )
    };
    type Config = LeapProfile;
    type Open = LeapOpen;
    type Emulate = LeapEmulate;

    fn table(&self, side: Side, _config: &LeapProfile) -> DeviceTable {
        super::table::table(side)
    }

    fn configure(&self, spec: &DeviceSpec<'_, LeapProfile>) -> Result<LeapOpen, DeviceError> {
        let c: LeapConfig = spec.config.section();
        let ids = c.ids();
        let bus = LeapBusConfig {
            ids: ids.clone(),
            baud: c.baud,
            goal_current_ma: c.goal_current_ma(),
            fast_sync_read: c.fast_sync_read,
            rate_hz: spec.rate_hz,
            stale_after: spec.stale_after,
            response_grace: std::time::Duration::from_millis(c.response_grace_ms.unwrap_or(2)),
        };
        let emulated = (spec.backend == Backend::Emulator).then(|| {
            let mut e = EmulatorConfig::with_ids(&ids);
            e.baud = c.baud;
            e.noise = spec.emulator.noise_for(spec.name, XC330_NOISE);
            for (servo, name) in e.servos.iter_mut().zip(JOINTS) {
                servo.start_rad = spec.initial_wire(name, WIRE_OFFSET);
                servo.object_at_rad = spec.object_wire(name);
            }
            e
        });
        Ok(LeapOpen {
            port: c.port,
            bus,
            emulated,
        })
    }

    fn open(
        &self,
        open: LeapOpen,
        spec: &DeviceSpec<'_, LeapProfile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        let connector: Box<dyn Connector> = match open.emulated {
            Some(cfg) => {
                // The emulated servos answer on the device loop's own thread.
                let (emu, connector) = super::emulator::in_process(cfg);
                env.shared.insert::<Arc<Mutex<LeapEmulator>>>(spec.name, emu);
                connector
            }
            None => Box::new(SerialConnector {
                path: PathBuf::from(&open.port),
                baud: open.bus.baud,
            }),
        };
        Ok(Box::new(LeapDevice::start(spec.info(), connector, open.bus)?))
    }

    fn emulate(&self, args: &EmulateArgs, options: LeapEmulate) -> Result<(String, Emulation), DeviceError> {
        let ids = super::control_table::DEFAULT_IDS;
        let link = options
            .pty
            .unwrap_or_else(|| std::env::temp_dir().join(format!("handgate-{}-leap-emulate", std::process::id())));
        let mut cfg = EmulatorConfig::with_ids(&ids);
        cfg.noise = args.noise(XC330_NOISE);
        let hand = VirtualLeap::start(&link, cfg).map_err(DeviceError::link)?;
        let what = format!(
            "emulating a LEAP Hand ({:?}: 16 XC330, ids 0-15) at {} baud on {}",
            options.variant,
            super::control_table::BAUD,
            hand.path().display()
        );
        Ok((what, Emulation::Running(Box::new(hand))))
    }
}

/// What a LEAP Hand opens with: decided from the profile, before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub struct LeapOpen {
    pub port: String,
    pub bus: LeapBusConfig,
    /// Emulator backend: the emulated hand.
    pub emulated: Option<EmulatorConfig>,
}

/// `handgate emulate leap`'s own options.
#[derive(Debug, Default)]
pub struct LeapEmulate {
    /// Where to link the pseudo-terminal (default: a temporary path).
    pub pty: Option<PathBuf>,
    /// Which hand (printed; the emulated servos take whatever goal current a client writes).
    pub variant: Variant,
}

impl EmulateOptions for LeapEmulate {
    const COMMON: &'static [&'static str] = &["side", "no-noise", "seed"];
    const OPTIONS: &'static [EmulateOption] = &[
        EmulateOption {
            name: "pty",
            value: Some("PATH"),
            help: "where to link the bus's pseudo-terminal (default: a temporary path); give it as leap.port",
        },
        EmulateOption {
            name: "full",
            value: None,
            help: "a full LEAP Hand rather than a Lite (the banner only: the goal current is the client's to write)",
        },
    ];

    fn set(&mut self, name: &str, value: Option<&str>) -> Result<(), String> {
        match name {
            "pty" => self.pty = Some(value.unwrap_or_default().into()),
            _ => self.variant = Variant::Full,
        }
        Ok(())
    }
}
