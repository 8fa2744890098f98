//! The Dex1 service front: what dex1_1_service and SAKE's EZGripper driver serve, so a client
//! written for either (xr_teleoperate included) works unchanged. Variants as in
//! `handgate_adapters::dex1::adapter::Variant`: `go` (default: `rt/dex1/{side}/*`, unitree_go
//! MotorCmds_/MotorStates_, 1 element), `hg` (seed spec: HandCmd_/HandState_, 1 motor),
//! `actuator` (`rt/unitree_actuator/*`, 2 elements, index 0 right, 1 left).
//!
//! Command rules: exact element count; finite values; `mode` ignored (as dex1_1_service does);
//! q outside [0, range] is clamped by the device table. State: q clamped to [0, range] (a
//! client must never see q > range: docs/sources.md §5's 5.4000001 bug), tau_est, temperature, mode =
//! the device's status byte (EZGripper grasp state), a hardware fault gives mode 255 and
//! lost = 0xFFFFFFFF; while the state is stale, `lost` carries the age of the last
//! measurement in ms (saturating at 0xFFFFFFFE) and `reserve[1]` = 1.

use handgate_adapters::dex1::adapter::{actuator_index, Variant, LOST_FAULT, MODE_FAULT};
use handgate_adapters::mapping::{DeviceTable, WireTarget};
use handgate_adapters::model::{faults, Freshness, HandState, JointState, Side};
use handgate_idl::{unitree_go, unitree_hg};

use super::{checked_target, FrontCommand, Rejection};
use crate::profile::Topic;

fn one(front: &DeviceTable, w: WireTarget, tag: u32) -> FrontCommand {
    FrontCommand {
        joints: vec![Some(front.joints[0].from_wire(&w))],
        timeout_bit: false,
        tag,
    }
}

/// Decodes unitree_go MotorCmds_ for the `go` or `actuator` variant.
pub fn decode_go(
    msg: &unitree_go::MotorCmds_,
    variant: Variant,
    side: Side,
    front: &DeviceTable,
) -> Result<FrontCommand, Rejection> {
    let (want, idx) = match variant {
        Variant::Actuator => (2, actuator_index(side)),
        _ => (1, 0),
    };
    if msg.cmds.len() != want {
        return Err(Rejection::WrongCount {
            got: msg.cmds.len(),
            want,
        });
    }
    let m = &msg.cmds[idx];
    Ok(one(
        front,
        checked_target(idx, [m.q, m.dq, m.tau, m.kp, m.kd])?,
        m.reserve[0],
    ))
}

/// Decodes the `actuator` variant's 2-element MotorCmds_ for the bound elements
/// (`bound[i]` = (element, that gripper's front table)). The message is checked whole first:
/// two elements, every field of both finite (an unbound element included), so a bad
/// message moves neither gripper. Returns one command per bound element, in `bound`'s order.
pub fn decode_actuator(
    msg: &unitree_go::MotorCmds_,
    bound: &[(usize, &DeviceTable)],
) -> Result<Vec<FrontCommand>, Rejection> {
    if msg.cmds.len() != 2 {
        return Err(Rejection::WrongCount {
            got: msg.cmds.len(),
            want: 2,
        });
    }
    let targets = msg
        .cmds
        .iter()
        .enumerate()
        .map(|(i, m)| checked_target(i, [m.q, m.dq, m.tau, m.kp, m.kd]))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(bound
        .iter()
        .map(|&(e, table)| one(table, targets[e], msg.cmds[e].reserve[0]))
        .collect())
}

/// An `actuator` element no device is bound to: never measured, so reported as the stale
/// convention says (`reserve[1]` = 1, `lost` = the saturated age 0xFFFFFFFE) at the open
/// position, where a Dex1 powers up; commands for it are ignored.
pub fn unbound_state(front: &DeviceTable) -> unitree_go::MotorState_ {
    let q = front.joints[0].q_to_wire(0.0);
    unitree_go::MotorState_ {
        q,
        q_raw: q,
        lost: UNBOUND_LOST,
        reserve: [0, 1],
        ..Default::default()
    }
}

/// `lost` of an unbound actuator element (the stale age, saturated: never measured).
pub const UNBOUND_LOST: u32 = 0xFFFF_FFFE;

/// Decodes the seed spec's HandCmd_ (1 motor).
pub fn decode_hg(msg: &unitree_hg::HandCmd_, front: &DeviceTable) -> Result<FrontCommand, Rejection> {
    if msg.motor_cmd.len() != 1 {
        return Err(Rejection::WrongCount {
            got: msg.motor_cmd.len(),
            want: 1,
        });
    }
    let m = &msg.motor_cmd[0];
    Ok(one(
        front,
        checked_target(0, [m.q, m.dq, m.tau, m.kp, m.kd])?,
        msg.reserve[0],
    ))
}

/// One gripper's unitree_go MotorState_ from the routed joint state.
pub fn go_state(
    front: &DeviceTable,
    joint: &JointState,
    st: &HandState,
    now: std::time::Instant,
) -> unitree_go::MotorState_ {
    let j = &front.joints[0];
    let range = j.limits.max.max(j.limits.min);
    let q = j.q_to_wire(joint.q);
    let q = if q.is_finite() {
        q.clamp(0.0, j.q_to_wire(0.0).max(j.q_to_wire(range)))
    } else {
        0.0
    };
    let fault = st.faults & faults::HARDWARE != 0;
    let stale = st.freshness == Freshness::Stale;
    let lost = if fault {
        LOST_FAULT
    } else if stale {
        st.age(now)
            .map(|a| a.as_millis().min(u128::from(UNBOUND_LOST)) as u32)
            .unwrap_or(UNBOUND_LOST)
    } else {
        0
    };
    unitree_go::MotorState_ {
        mode: if fault { MODE_FAULT } else { st.mode },
        q,
        dq: j.rate_to_wire(joint.dq),
        ddq: 0.0,
        tau_est: j.tau_to_wire(joint.tau),
        q_raw: q,
        dq_raw: 0.0,
        ddq_raw: 0.0,
        temperature: joint.temperature.unwrap_or(0.0).round().clamp(0.0, 255.0) as u8,
        lost,
        reserve: [st.cmd_tag, u32::from(stale)],
    }
}

/// MotorStates_ for the `go` (1 element) variant.
pub fn encode_go(
    front: &DeviceTable,
    joint: &JointState,
    st: &HandState,
    now: std::time::Instant,
) -> unitree_go::MotorStates_ {
    unitree_go::MotorStates_ {
        states: vec![go_state(front, joint, st, now)],
    }
}

/// HandState_ for the `hg` variant.
pub fn encode_hg(
    front: &DeviceTable,
    joint: &JointState,
    st: &HandState,
    now: std::time::Instant,
) -> unitree_hg::HandState_ {
    let g = go_state(front, joint, st, now);
    let mut out = unitree_hg::HandState_::with_sizes(1, 0);
    let t = g.temperature as i16;
    out.motor_state[0] = unitree_hg::MotorState_ {
        mode: g.mode,
        q: g.q,
        dq: g.dq,
        tau_est: g.tau_est,
        temperature: [t, t],
        motorstate: u32::from(g.lost == LOST_FAULT),
        ..Default::default()
    };
    out.reserve = [st.cmd_tag, u32::from(st.freshness == Freshness::Stale)];
    out
}

/// The Dex1 front's state writer, of the variant's type.
enum Dex1Writer {
    Go(handgate_adapters::dds::Writer<unitree_go::MotorStates_>),
    Hg(handgate_adapters::dds::Writer<unitree_hg::HandState_>),
}

/// The Dex1 front's endpoints in its wire variant.
pub struct Dex1Io {
    variant: Variant,
    /// Elements of its messages (the actuator variant: 2).
    elements: usize,
    /// The command reader, of the variant's type (kept alive).
    _reader: Box<dyn Send>,
    writer: Dex1Writer,
}

impl Dex1Io {
    pub fn open(
        node: &handgate_adapters::dds::Node,
        variant: Variant,
        cmd_topic: &str,
        state_topic: &str,
        elements: usize,
        tx: tokio::sync::mpsc::Sender<super::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Self, handgate_adapters::dds::DdsError> {
        use handgate_adapters::dds::Qos;
        let (reader, writer): (Box<dyn Send>, _) = match variant {
            Variant::Hg => (
                Box::new(super::reader::<unitree_hg::HandCmd_>(node, cmd_topic, tx, dropped)?),
                Dex1Writer::Hg(node.writer(state_topic, Qos::BestEffort)?),
            ),
            Variant::Go | Variant::Actuator => (
                Box::new(super::reader::<unitree_go::MotorCmds_>(node, cmd_topic, tx, dropped)?),
                Dex1Writer::Go(node.writer(state_topic, Qos::BestEffort)?),
            ),
        };
        Ok(Self {
            variant,
            elements,
            _reader: reader,
            writer,
        })
    }
}

impl super::FrontIo for Dex1Io {
    fn decode(
        &self,
        bound: &[super::Bound<'_>],
        msg: &super::Message,
    ) -> Result<Vec<(usize, super::Routed)>, Rejection> {
        let b0 = &bound[0];
        if let Some(m) = msg.downcast_ref::<unitree_hg::HandCmd_>() {
            return Ok(vec![(0, super::routed(b0.route, decode_hg(m, &b0.route.front)?))]);
        }
        let Some(m) = msg.downcast_ref::<unitree_go::MotorCmds_>() else {
            return Ok(Vec::new());
        };
        if self.variant == Variant::Actuator {
            let elems: Vec<(usize, &DeviceTable)> = bound.iter().map(|b| (b.element, &*b.route.front)).collect();
            return Ok(decode_actuator(m, &elems)?
                .into_iter()
                .zip(bound)
                .enumerate()
                .map(|(i, (c, b))| (i, super::routed(b.route, c)))
                .collect());
        }
        let c = decode_go(m, Variant::Go, Side::Left, &b0.route.front)?;
        Ok(vec![(0, super::routed(b0.route, c))])
    }

    fn publish(&mut self, bound: &[super::Bound<'_>], _lf: bool) {
        let now = std::time::Instant::now();
        let b0 = &bound[0];
        let _ = match &mut self.writer {
            Dex1Writer::Go(w) if self.variant == Variant::Actuator => {
                // Every element measured: each from its own gripper; an unbound one as never
                // measured.
                let mut m = unitree_go::MotorStates_ {
                    states: vec![unbound_state(&b0.route.front); self.elements],
                };
                for b in bound {
                    m.states[b.element] = go_state(&b.route.front, &b.routed_state()[0], &b.state, now);
                }
                w.write(m)
            }
            Dex1Writer::Go(w) => w.write(encode_go(&b0.route.front, &b0.routed_state()[0], &b0.state, now)),
            Dex1Writer::Hg(w) => w.write(encode_hg(&b0.route.front, &b0.routed_state()[0], &b0.state, now)),
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use handgate_adapters::mapping::TableOverrides;
    use handgate_adapters::model::DeviceKind;

    fn t() -> DeviceTable {
        DeviceKind::Dex1.table(Side::Left, &TableOverrides::default()).unwrap()
    }

    #[test]
    fn go_counts_and_finiteness() {
        let f = t();
        let mut m = unitree_go::MotorCmds_::with_len(1);
        m.cmds[0].q = 5.4;
        let d = decode_go(&m, Variant::Go, Side::Left, &f).unwrap();
        assert!(
            (d.joints[0].unwrap().q - 0.0).abs() < 1e-6,
            "5.4 rad = open = canonical 0"
        );
        assert!(decode_go(&unitree_go::MotorCmds_::with_len(2), Variant::Go, Side::Left, &f).is_err());
        assert!(decode_go(&unitree_go::MotorCmds_::default(), Variant::Go, Side::Left, &f).is_err());
        m.cmds[0].q = f32::INFINITY;
        assert_eq!(decode_go(&m, Variant::Go, Side::Left, &f), Err(Rejection::NonFinite(0)));
    }

    #[test]
    fn actuator_reads_its_side_index() {
        let f = t();
        let mut m = unitree_go::MotorCmds_::with_len(2);
        m.cmds[0].q = 1.0;
        m.cmds[1].q = 4.0;
        let d = decode_go(&m, Variant::Actuator, Side::Left, &f).unwrap();
        assert!((d.joints[0].unwrap().q - 1.4).abs() < 1e-5);
    }

    #[test]
    fn actuator_decodes_both_elements_and_refuses_a_bad_one_whole() {
        let f = t();
        let mut m = unitree_go::MotorCmds_::with_len(2);
        m.cmds[0].q = 1.0;
        m.cmds[1].q = 4.0;
        let both = decode_actuator(&m, &[(0, &f), (1, &f)]).unwrap();
        assert!(
            (both[0].joints[0].unwrap().q - 4.4).abs() < 1e-5,
            "right: 1.0 rad = 4.4 closed"
        );
        assert!(
            (both[1].joints[0].unwrap().q - 1.4).abs() < 1e-5,
            "left: 4.0 rad = 1.4 closed"
        );
        let left_only = decode_actuator(&m, &[(1, &f)]).unwrap();
        assert_eq!(left_only.len(), 1);
        assert!((left_only[0].joints[0].unwrap().q - 1.4).abs() < 1e-5);
        // A NaN in the unbound element still refuses the whole message.
        m.cmds[0].kp = f32::NAN;
        assert_eq!(decode_actuator(&m, &[(1, &f)]), Err(Rejection::NonFinite(0)));
        assert!(decode_actuator(&unitree_go::MotorCmds_::with_len(1), &[(0, &f)]).is_err());
    }

    #[test]
    fn unbound_actuator_element_reports_open_and_never_measured() {
        let s = unbound_state(&t());
        assert!((s.q - 5.4).abs() < 1e-5, "{}", s.q);
        assert_eq!((s.lost, s.reserve[1]), (UNBOUND_LOST, 1));
    }

    #[test]
    fn state_q_never_exceeds_range_and_fault_markers() {
        let f = t();
        let now = std::time::Instant::now();
        let st = HandState {
            freshness: Freshness::Fresh,
            ..Default::default()
        };
        let s = go_state(
            &f,
            &JointState {
                q: -0.0001,
                ..Default::default()
            },
            &st,
            now,
        );
        assert!(s.q <= 5.4, "{}", s.q);
        let bad = HandState {
            faults: faults::HARDWARE,
            ..Default::default()
        };
        let s = go_state(&f, &JointState::default(), &bad, now);
        assert_eq!((s.mode, s.lost), (255, 0xFFFF_FFFF));
    }
}

/// A Dex1 front must publish state at least this fast: xr_teleoperate runs its gripper loop
/// at 200 Hz (docs/sources.md §4).
pub const MIN_STATE_HZ: f64 = 200.0;

/// The Dex1-1 service interface, in its wire variants.
#[derive(Debug)]
pub struct Dex1Front;

impl super::kind::FrontFactory for Dex1Front {
    fn name(&self) -> &'static str {
        "dex1"
    }
    fn speaks(&self) -> Option<handgate_adapters::model::DeviceKind> {
        Some(handgate_adapters::model::DeviceKind::Dex1)
    }
    fn keys(&self) -> &'static [&'static str] {
        &["side", "variant"]
    }
    fn default_topics(
        &self,
        f: &crate::profile::FrontConfig,
        lr: Option<Side>,
        _device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        let variant = f.dex1_variant();
        // The actuator variant's topics carry both sides.
        let std = (variant == Variant::Actuator)
            .then_some(Side::Left)
            .or(lr)
            .map(|s| variant.topics(s));
        (std.as_ref().map(|t| Topic(t.0.clone())), std.map(|t| Topic(t.1)), None)
    }
    fn default_state_hz(&self, _device_hz: Option<f64>) -> f64 {
        500.0
    }
    fn default_name(&self, f: &crate::profile::FrontConfig, side: &str) -> String {
        if f.dex1_variant() == Variant::Actuator {
            "dex1_actuator".into()
        } else {
            format!("dex1_{side}")
        }
    }
    fn silence(
        &self,
        mode: crate::profile::Silence,
        dog: (std::time::Duration, handgate_adapters::model::SafeAction),
    ) -> crate::plan::SilencePlan {
        let after = match mode {
            crate::profile::Silence::Watchdog => dog,
            // dex1_1_service brakes: holds the measured position 1 s after the last command.
            crate::profile::Silence::Service => (
                handgate_adapters::dex1::SERVICE_BRAKE_AFTER,
                handgate_adapters::model::SafeAction::Hold,
            ),
        };
        crate::plan::SilencePlan {
            mode,
            after: Some(after),
            timeout_bit: None,
        }
    }
    fn elements(&self, f: &crate::profile::FrontConfig) -> usize {
        if f.dex1_variant() == Variant::Actuator {
            2
        } else {
            1
        }
    }
    fn binds_elements(&self) -> Option<&'static str> {
        Some("an actuator dex1 front")
    }
    fn element(&self, f: &crate::profile::FrontConfig, side: Side) -> usize {
        if f.dex1_variant() == Variant::Actuator {
            actuator_index(side)
        } else {
            0
        }
    }
    fn validate(
        &self,
        f: &crate::profile::FrontConfig,
        served: Option<Side>,
        dangling: bool,
    ) -> Vec<(&'static str, String)> {
        let mut out = vec![];
        if let Some(r) = f.state_hz {
            if r.0.is_finite() && r.0 < MIN_STATE_HZ {
                out.push((
                    "state_hz",
                    format!("a dex1 front publishes state at {MIN_STATE_HZ} Hz or faster (xr_teleoperate's loop rate), got {}", r.0),
                ));
            }
        }
        if !dangling {
            let given = f.cmd_topic.is_some() && f.state_topic.is_some();
            out.extend(super::dex3::side_rule(
                "dex1",
                served,
                given,
                f.dex1_variant() == Variant::Actuator,
            ));
        }
        out
    }
    fn describe(&self, f: &crate::profile::FrontConfig) -> Option<String> {
        Some(format!(" ({})", f.dex1_variant()))
    }
    fn open(
        &self,
        node: &handgate_adapters::dds::Node,
        f: &crate::plan::FrontPlan,
        tx: tokio::sync::mpsc::Sender<super::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<super::Endpoints, handgate_adapters::dds::DdsError> {
        let cmd = f.cmd_topic.clone().unwrap_or_default();
        Ok(super::Endpoints::Commands(Box::new(Dex1Io::open(
            node,
            f.config.dex1_variant(),
            &cmd,
            &f.state_topic,
            f.elements(),
            tx,
            dropped,
        )?)))
    }
}

impl super::FrontKind {
    /// The Dex1-1 DDS interface (`rt/dex1/{side}/*` or `rt/unitree_actuator/*`).
    #[allow(non_upper_case_globals)]
    pub const Dex1: super::FrontKind = super::FrontKind::of(&Dex1Front);
}
