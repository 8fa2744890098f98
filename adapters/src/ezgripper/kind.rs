//! The SAKE EZGripper as a registered device kind: its facts and table; how grippers open
//! (one bus per port) is `super::open`.

use std::collections::HashMap;

use super::config::EzProfile;
use super::open::{EzEmulate, EzOpen};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    DeviceKind, EmulateArgs, Emulation, FleetMember, FleetProblem, Kind, KindFacts, Problem, Rates, SectionSpec,
};
use crate::mapping::DeviceTable;
use crate::model::{Side, GRIPPER_JOINTS};
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// SAKE EZGripper (Dynamixel MX-64 over serial).
    #[allow(non_upper_case_globals)]
    pub const Ezgripper: DeviceKind = DeviceKind::of(&EzGripperKind);
}

/// The SAKE EZGripper.
#[derive(Debug, Clone, Copy)]
pub struct EzGripperKind;

impl Kind for EzGripperKind {
    const FACTS: KindFacts = KindFacts {
        sections: &[SectionSpec {
            key: "ezgripper",
            backends: &[Backend::Serial, Backend::Emulator],
        }],
        // As fast as the bus answers.
        ..KindFacts::new(
            "ezgripper",
            &GRIPPER_JOINTS,
            &[Backend::Serial, Backend::Emulator],
            Rates::AS_FAST_AS_THE_BUS,
        )
    };
    type Config = EzProfile;
    type Open = EzOpen;
    type Emulate = EzEmulate;
    const EMULATOR_FAULTS: &'static [&'static str] = &["stuck", "frozen", "ignore-commands"];

    fn table(&self, side: Side, config: &EzProfile) -> DeviceTable {
        let pct = config.section().max_open_percent;
        super::table::table(side, super::table::DEFAULT_RANGE_RAD, f32::from(pct))
    }

    /// Grippers on one port share one baud and need distinct servo ids.
    fn validate_fleet(&self, members: &[FleetMember<'_, EzProfile>]) -> Vec<FleetProblem> {
        let mut out = Vec::new();
        let mut ports: HashMap<String, (usize, u32)> = HashMap::new();
        let mut ids: HashMap<(String, u8), usize> = HashMap::new();
        for m in members.iter().filter(|m| m.ctx.backend == Backend::Serial) {
            let e = m.config.section();
            match ports.get(&e.port) {
                Some(&(j, baud)) if baud != e.baud => out.push((
                    m.index,
                    Problem::new(
                        &["ezgripper", "baud"],
                        format!("devices[{j}] uses {} at {baud} baud; one bus has one baud rate", e.port),
                    ),
                )),
                Some(_) => {}
                None => {
                    ports.insert(e.port.clone(), (m.index, e.baud));
                }
            }
            let id = e.servo_id_for(m.ctx.side);
            if let Some(j) = ids.insert((e.port.clone(), id), m.index) {
                out.push((
                    m.index,
                    Problem::new(
                        &["ezgripper", "servo_id"],
                        format!("servo id {id} on {} is also devices[{j}]", e.port),
                    ),
                ));
            }
        }
        out
    }

    fn prepare(&self, devices: &[DeviceSpec<'_, EzProfile>], env: &mut OpenEnv<'_>) -> Result<(), DeviceError> {
        super::open::prepare(devices, env)
    }

    fn configure(&self, spec: &DeviceSpec<'_, EzProfile>) -> Result<EzOpen, DeviceError> {
        super::open::configure(spec)
    }

    fn emulate(&self, args: &EmulateArgs, options: EzEmulate) -> Result<(String, Emulation), DeviceError> {
        super::open::emulate(args, options)
    }

    fn open(
        &self,
        open: EzOpen,
        spec: &DeviceSpec<'_, EzProfile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        super::open::open(open, spec, env)
    }
}
