//! Table-driven mapping between the canonical model and each device's wire frame.
//!
//! One [`DeviceTable`] per device kind and side: for every canonical joint, its index in the
//! wire message, its URDF joint name, and the affine map
//! `wire_q = offset + sign * scale * canonical_q` (velocities scale without the offset, gains
//! scale inversely so that the same torque results), plus canonical limits, the closure map
//! and the hold gains. Each kind's folder builds its table (`dex3::table`, `dex1::table`, ...);
//! the router and the adapters only ever go through this module, so adding a device kind is a
//! new folder and a new table.

use serde::{Deserialize, Serialize};

use crate::model::{CommandBody, DeviceKind, JointCommand, JointId, JointState, SafeAction, Side};
use crate::sim::MotorTarget;

/// A joint command in the device's own frame and units (its wire values).
pub type WireTarget = MotorTarget;

/// The five command fields of a wire target in a unitree_go motor command (mode 0: the
/// caller sets it where it means something).
impl From<WireTarget> for handgate_idl::unitree_go::MotorCmd_ {
    fn from(w: WireTarget) -> Self {
        Self {
            mode: 0,
            q: w.q,
            dq: w.dq,
            tau: w.tau,
            kp: w.kp,
            kd: w.kd,
            reserve: Default::default(),
        }
    }
}

/// The five command fields of a wire target in a unitree_hg motor command (mode 0: the caller
/// sets it where it means something, e.g. the Dex3 RIS byte).
impl From<WireTarget> for handgate_idl::unitree_hg::MotorCmd_ {
    fn from(w: WireTarget) -> Self {
        Self {
            mode: 0,
            q: w.q,
            dq: w.dq,
            tau: w.tau,
            kp: w.kp,
            kd: w.kd,
            reserve: Default::default(),
        }
    }
}

/// Inclusive range in canonical units (rad, positive = closing).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    pub min: f32,
    pub max: f32,
    /// The limits are the hardware's own hard stops (the kind's table says so; a profile's
    /// `[devices.limits.joints]` never does): a target past one is the stop pushed into, as
    /// the hand's own service does ([`DeviceTable::sanitize`], docs/model.md "Limits").
    pub stops: bool,
}

impl Limits {
    /// Soft limits: a target past one is clamped to it.
    pub fn new(min: f32, max: f32) -> Self {
        Self { min, max, stops: false }
    }

    /// Limits at the hardware's hard stops (see [`Limits::stops`]).
    pub fn at_stops(min: f32, max: f32) -> Self {
        Self { min, max, stops: true }
    }
    pub fn clamp(&self, v: f32) -> f32 {
        v.clamp(self.min, self.max)
    }
    pub fn contains(&self, v: f32) -> bool {
        v >= self.min && v <= self.max
    }
    pub fn span(&self) -> f32 {
        self.max - self.min
    }
}

/// One canonical joint's mapping onto the wire.
#[derive(Debug, Clone, PartialEq)]
pub struct JointMap {
    /// Canonical name (`index_0`, `jaw`, `motor_2`).
    pub name: &'static str,
    /// Index of this joint in the wire message's motor array (IDL order).
    pub wire_index: usize,
    /// URDF joint name (for JointState), e.g. `left_hand_three_joint`.
    pub urdf: String,
    /// +1 or -1: wire direction of canonical "closing".
    pub sign: f32,
    /// Wire units per canonical unit (1 for rad<->rad; percent per rad for the EZGripper).
    pub scale: f32,
    /// Wire position at canonical 0.
    pub offset: f32,
    /// Canonical limits.
    pub limits: Limits,
}

impl JointMap {
    pub fn q_to_wire(&self, q: f32) -> f32 {
        self.offset + self.sign * self.scale * q
    }
    pub fn q_from_wire(&self, w: f32) -> f32 {
        (w - self.offset) / (self.sign * self.scale)
    }
    pub fn rate_to_wire(&self, v: f32) -> f32 {
        self.sign * self.scale * v
    }
    pub fn rate_from_wire(&self, w: f32) -> f32 {
        w / (self.sign * self.scale)
    }
    /// Torque: wire torque has the wire's sign; its unit is N*m on every device that has one.
    pub fn tau_to_wire(&self, t: f32) -> f32 {
        self.sign * t
    }
    pub fn tau_from_wire(&self, w: f32) -> f32 {
        self.sign * w
    }
    /// Gains keep `kp * error` the same torque: kp_wire = kp / scale.
    pub fn gain_to_wire(&self, k: f32) -> f32 {
        k / self.scale
    }
    pub fn gain_from_wire(&self, k: f32) -> f32 {
        k * self.scale
    }

    pub fn to_wire(&self, c: &JointCommand) -> WireTarget {
        WireTarget {
            q: self.q_to_wire(c.q),
            dq: self.rate_to_wire(c.dq),
            tau: self.tau_to_wire(c.tau),
            kp: self.gain_to_wire(c.kp),
            kd: self.gain_to_wire(c.kd),
        }
    }

    pub fn from_wire(&self, w: &WireTarget) -> JointCommand {
        JointCommand {
            q: self.q_from_wire(w.q),
            dq: self.rate_from_wire(w.dq),
            tau: self.tau_from_wire(w.tau),
            kp: self.gain_from_wire(w.kp),
            kd: self.gain_from_wire(w.kd),
        }
    }
}

/// How a hand-level closure in [0, 1] becomes joint commands.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "type")]
pub enum ClosureMap {
    /// Linear between two canonical postures (one position per joint), held with kp/kd.
    Postures {
        open: Vec<f32>,
        closed: Vec<f32>,
        kp: f32,
        kd: f32,
    },
    /// Feed-forward torque only, the same on every joint (rt/hand_sdk: +tau closes).
    Torque { open: f32, closed: f32 },
}

/// What a profile may change on any kind's table: the per-step limit, joint limits, the
/// closure map's ends. (A kind's own knobs, such as the Dex1 open range, are in its config:
/// `KindFactory::table`.)
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TableOverrides {
    /// Largest |target - measured| per command, rad.
    pub max_step: Option<f32>,
    /// Joint limits by canonical name.
    pub limits: Vec<(String, Limits)>,
    /// Closure postures (one position per joint, canonical order) replacing the table's own
    /// (posture maps only).
    pub open_posture: Option<Vec<f32>>,
    pub closed_posture: Option<Vec<f32>>,
    /// Feed-forward torque at closure 0 / 1, N*m (torque maps only).
    pub tau_open: Option<f32>,
    pub tau_closed: Option<f32>,
    /// The motion detector's tolerance (rad) and hold time replacing the kind's.
    pub motion_tolerance: Option<f32>,
    pub motion_hold: Option<std::time::Duration>,
    /// What shows contact (a grasp: `motion::Verdict::Holding`) replacing the kind's rule.
    pub motion_contact: Option<crate::motion::Contact>,
}

/// Errors mapping a command onto a device.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MappingError {
    #[error("joint id {0} out of range for a {1} ({2} joints)")]
    UnknownJoint(u8, DeviceKind, usize),
    #[error("unknown joint {0:?} for a {1}")]
    UnknownJointName(String, DeviceKind),
    #[error("non-finite value in the command for joint {0}")]
    NonFinite(&'static str),
    #[error("closure {0} is not a finite number")]
    BadClosure(f32),
    #[error("table for {0} has {1} joints but the closure map has {2}")]
    ClosureShape(DeviceKind, usize, usize),
}

/// The complete mapping of one device.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceTable {
    pub kind: DeviceKind,
    pub side: Side,
    /// In canonical order.
    pub joints: Vec<JointMap>,
    pub closure: ClosureMap,
    /// Gains used to hold a measured position (safe state "hold", re-seeding after reconnect).
    pub hold_kp: f32,
    pub hold_kd: f32,
    /// Largest allowed |target - measured| per command, rad (None = no per-step limit).
    pub max_step: Option<f32>,
    /// Largest stiffness/damping a command may ask for (canonical units).
    pub max_kp: f32,
    pub max_kd: f32,
    /// Largest |feed-forward torque|, N*m.
    pub max_tau: f32,
    /// The frame of the URDF joint angles `rt/joint_states` publishes.
    pub urdf_frame: UrdfFrame,
    /// When a joint that does not follow its target is reported ([`crate::motion`]; profile
    /// `[devices.motion]`).
    pub motion: crate::motion::MotionThresholds,
}

/// A command body that passed [`DeviceTable::check`] for a device's table: every joint it
/// names exists, every value is finite, a closure is finite and the closure map fits. Only
/// [`DeviceTable::checked`] builds one.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckedBody(CommandBody);

impl CheckedBody {
    pub fn body(&self) -> &CommandBody {
        &self.0
    }

    pub fn into_body(self) -> CommandBody {
        self.0
    }
}

/// Which of a table's frames the kind's URDF joint angles are in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UrdfFrame {
    /// The wire value is the URDF angle (Dex3: the service's q is the joint angle).
    #[default]
    Wire,
    /// The canonical value is the URDF angle (hands whose wire is a normalised 0..1 while the
    /// table's canonical radians are the URDF's: Inspire, BrainCo).
    Canonical,
}

impl DeviceTable {
    /// A position-controlled hand's table: commands hold with the closure postures' gains,
    /// no per-step limit, the common bounds on a command (stiffness 50, damping 5, torque
    /// 5 N·m).
    pub fn with_postures(
        kind: DeviceKind,
        side: Side,
        joints: Vec<JointMap>,
        (open, closed): (Vec<f32>, Vec<f32>),
        (kp, kd): (f32, f32),
        urdf_frame: UrdfFrame,
    ) -> Self {
        DeviceTable {
            kind,
            side,
            joints,
            closure: ClosureMap::Postures { open, closed, kp, kd },
            hold_kp: kp,
            hold_kd: kd,
            max_step: None,
            max_kp: 50.0,
            max_kd: 5.0,
            max_tau: 5.0,
            urdf_frame,
            motion: crate::motion::MotionThresholds::HAND,
        }
    }

    /// A parallel gripper's table: one jaw joint (`{side}_gripper_joint`), 0 open ..= `range`
    /// rad closed, the wire reading `offset - scale × q` (open at `offset`).
    pub fn gripper(kind: DeviceKind, side: Side, range: f32, (scale, offset): (f32, f32), gains: (f32, f32)) -> Self {
        let jaw = JointMap {
            name: crate::model::GRIPPER_JOINTS[0],
            wire_index: 0,
            urdf: format!("{}_gripper_joint", side.as_str()),
            sign: -1.0,
            scale,
            offset,
            limits: Limits::new(0.0, range),
        };
        Self {
            motion: crate::motion::MotionThresholds::GRIPPER,
            ..Self::with_postures(kind, side, vec![jaw], (vec![0.0], vec![range]), gains, UrdfFrame::Wire)
        }
    }
    pub fn joint_count(&self) -> usize {
        self.joints.len()
    }

    /// Whether `body` names only some joints (the others keep their targets, or are held
    /// where they were measured).
    pub fn is_partial(&self, body: &CommandBody) -> bool {
        match body {
            CommandBody::Joints(list) => (0..self.joints.len()).any(|i| !list.iter().any(|(id, _)| id.index() == i)),
            _ => false,
        }
    }

    pub fn joint(&self, id: JointId) -> Result<&JointMap, MappingError> {
        self.joints
            .get(id.index())
            .ok_or(MappingError::UnknownJoint(id.0, self.kind, self.joints.len()))
    }

    pub fn joint_by_name(&self, name: &str) -> Result<JointId, MappingError> {
        self.joints
            .iter()
            .position(|j| j.name == name)
            .map(|i| JointId(i as u8))
            .ok_or_else(|| MappingError::UnknownJointName(name.to_string(), self.kind))
    }

    /// Number of motors in the wire message (max wire index + 1).
    pub fn wire_len(&self) -> usize {
        self.joints.iter().map(|j| j.wire_index + 1).max().unwrap_or(0)
    }

    /// Makes a canonical joint command safe for the device: non-finite → error, position
    /// clamped to limits and (when `measured` is known and the table has a per-step limit)
    /// to `measured ± max_step`, gains to [0, max], torque to ±max_tau.
    ///
    /// A target past a limit that is a hard stop ([`Limits::stops`]) becomes the stop as
    /// position and, as feed-forward torque, the pull its stiffness had past it
    /// (`kp · (target − stop)`, within ±max_tau with the command's own torque): the motor law
    /// `kp·(stop − q) + kp·(target − stop)` is `kp·(target − q)`, so the joint approaches the
    /// stop as fast as with the unclamped target and pushes into it with the torque the
    /// hand's service would give it (issue #37: a calibration that pushes a thumb past its
    /// range and reads where it stops; docs/model.md "Limits").
    pub fn sanitize(&self, id: JointId, c: &JointCommand, measured: Option<f32>) -> Result<JointCommand, MappingError> {
        let j = self.joint(id)?;
        if !c.is_finite() {
            return Err(MappingError::NonFinite(j.name));
        }
        let at_limit = j.limits.clamp(c.q);
        let mut q = at_limit;
        if let (Some(step), Some(m)) = (self.max_step, measured) {
            if m.is_finite() {
                q = q.clamp(m - step, m + step);
                q = j.limits.clamp(q);
            }
        }
        let kp = c.kp.clamp(0.0, self.max_kp);
        // Only where the position target is the stop itself (a per-step limit that holds the
        // target short of it keeps its meaning).
        let push = if j.limits.stops && q == at_limit {
            kp * (c.q - at_limit)
        } else {
            0.0
        };
        Ok(JointCommand {
            q,
            dq: c.dq.clamp(-100.0, 100.0),
            tau: (c.tau + push).clamp(-self.max_tau, self.max_tau),
            kp,
            kd: c.kd.clamp(0.0, self.max_kd),
        })
    }

    /// Hold every joint at its measured position with the hold gains.
    pub fn hold_measured(&self, measured: &[JointState]) -> Vec<JointCommand> {
        self.joints
            .iter()
            .enumerate()
            .map(|(i, j)| {
                let q = measured.get(i).map(|s| s.q).filter(|q| q.is_finite()).unwrap_or(0.0);
                JointCommand::hold(j.limits.clamp(q), self.hold_kp, self.hold_kd)
            })
            .collect()
    }

    /// Canonical targets for a closure in [0, 1] (clamped).
    pub fn closure_targets(&self, closure: f32, stiffness: Option<f32>) -> Result<Vec<JointCommand>, MappingError> {
        let mut out = Vec::with_capacity(self.joints.len());
        self.closure_targets_into(closure, stiffness, &mut out)?;
        Ok(out)
    }

    /// [`Self::closure_targets`] into `out`, its buffer reused.
    pub fn closure_targets_into(
        &self,
        closure: f32,
        stiffness: Option<f32>,
        out: &mut Vec<JointCommand>,
    ) -> Result<(), MappingError> {
        if !closure.is_finite() {
            return Err(MappingError::BadClosure(closure));
        }
        let c = closure.clamp(0.0, 1.0);
        out.clear();
        match &self.closure {
            ClosureMap::Postures { open, closed, kp, kd } => {
                if open.len() != self.joints.len() || closed.len() != self.joints.len() {
                    return Err(MappingError::ClosureShape(
                        self.kind,
                        self.joints.len(),
                        open.len().min(closed.len()),
                    ));
                }
                let kp = stiffness.filter(|s| s.is_finite()).unwrap_or(*kp);
                out.extend(
                    self.joints
                        .iter()
                        .enumerate()
                        .map(|(i, j)| JointCommand::hold(j.limits.clamp(open[i] + c * (closed[i] - open[i])), kp, *kd)),
                );
            }
            ClosureMap::Torque { open, closed } => {
                let tau = open + c * (closed - open);
                out.extend(self.joints.iter().map(|_| JointCommand {
                    tau,
                    ..Default::default()
                }));
            }
        }
        Ok(())
    }

    /// Estimated closure [0, 1] of canonical joint positions (mean over joints that move
    /// between the postures). Torque-mapped devices report NaN-free 0 unless `q` says more.
    pub fn closure_of(&self, q: &[f32]) -> f32 {
        self.closure_by(q.iter().copied())
    }

    /// [`Self::closure_of`] the positions of canonical joint states.
    pub fn closure_of_state(&self, joints: &[JointState]) -> f32 {
        self.closure_by(joints.iter().map(|j| j.q))
    }

    fn closure_by(&self, q: impl Iterator<Item = f32>) -> f32 {
        match &self.closure {
            ClosureMap::Postures { open, closed, .. } => {
                let mut sum = 0.0;
                let mut n = 0;
                for ((o, c), q) in open.iter().zip(closed).zip(q).take(self.joints.len()) {
                    let span = c - o;
                    if span.abs() > 1e-6 && q.is_finite() {
                        sum += ((q - o) / span).clamp(0.0, 1.0);
                        n += 1;
                    }
                }
                if n == 0 {
                    0.0
                } else {
                    sum / n as f32
                }
            }
            ClosureMap::Torque { .. } => 0.0,
        }
    }

    /// `body` checked once against this table ([`Self::check`]), as a type: a device given a
    /// [`CheckedBody`] of its table takes it without checking again (a front checks each
    /// command it routes once, the device's `command_checked` trusts it).
    pub fn checked(&self, body: CommandBody) -> Result<CheckedBody, MappingError> {
        self.check(&body)?;
        Ok(CheckedBody(body))
    }

    /// Whether `body` can be mapped safely, whatever the measured state: every joint id
    /// exists, every value of every joint command is finite, a closure is finite (the same
    /// errors [`Self::resolve`] would give, without building the targets).
    pub fn check(&self, body: &CommandBody) -> Result<(), MappingError> {
        match body {
            CommandBody::Joints(list) => {
                let mut last: Vec<Option<&JointCommand>> = vec![None; self.joints.len()];
                for (id, c) in list {
                    self.joint(*id)?;
                    last[id.index()] = Some(c);
                }
                for (j, c) in self.joints.iter().zip(last) {
                    if c.is_some_and(|c| !c.is_finite()) {
                        return Err(MappingError::NonFinite(j.name));
                    }
                }
                Ok(())
            }
            CommandBody::Closure { closure, .. } => {
                if !closure.is_finite() {
                    return Err(MappingError::BadClosure(*closure));
                }
                match &self.closure {
                    ClosureMap::Postures { open, closed, .. }
                        if open.len() != self.joints.len() || closed.len() != self.joints.len() =>
                    {
                        Err(MappingError::ClosureShape(
                            self.kind,
                            self.joints.len(),
                            open.len().min(closed.len()),
                        ))
                    }
                    _ => Ok(()),
                }
            }
            CommandBody::Safe(_) => Ok(()),
        }
    }

    /// Resolves a command body into a full set of sanitized canonical targets, given the
    /// previous targets (joints a partial command leaves out keep them) and the measured
    /// state (for per-step limits and holds).
    pub fn resolve(
        &self,
        body: &CommandBody,
        previous: Option<&[JointCommand]>,
        measured: &[JointState],
    ) -> Result<Vec<JointCommand>, MappingError> {
        let mut out = Vec::with_capacity(self.joints.len());
        self.resolve_into(body, previous, measured, &mut out)?;
        Ok(out)
    }

    /// [`Self::resolve`] into `out`, its buffer reused (a device loop resolves every command
    /// without allocating). After an error `out` holds no valid targets.
    pub fn resolve_into(
        &self,
        body: &CommandBody,
        previous: Option<&[JointCommand]>,
        measured: &[JointState],
        out: &mut Vec<JointCommand>,
    ) -> Result<(), MappingError> {
        let meas = |i: usize| measured.get(i).map(|s| s.q);
        out.clear();
        match body {
            CommandBody::Joints(list) => {
                match previous {
                    Some(p) if p.len() == self.joints.len() => out.extend_from_slice(p),
                    _ => out.extend(self.hold_measured(measured)),
                }
                for (id, c) in list {
                    self.joint(*id)?;
                    out[id.index()] = *c;
                }
            }
            CommandBody::Closure { closure, stiffness } => self.closure_targets_into(*closure, *stiffness, out)?,
            CommandBody::Safe(a) => {
                out.extend(self.safe_targets(*a, measured));
                return Ok(());
            }
        }
        for (i, c) in out.iter_mut().enumerate() {
            *c = self.sanitize(JointId(i as u8), c, meas(i))?;
        }
        Ok(())
    }

    /// Targets for a safe action.
    pub fn safe_targets(&self, action: SafeAction, measured: &[JointState]) -> Vec<JointCommand> {
        match action {
            SafeAction::Hold => self.hold_measured(measured),
            SafeAction::Limp => vec![JointCommand::default(); self.joints.len()],
            SafeAction::Open => self
                .closure_targets(0.0, None)
                .unwrap_or_else(|_| self.hold_measured(measured)),
        }
    }

    /// Canonical targets → wire targets in wire order (length [`Self::wire_len`]).
    pub fn to_wire(&self, targets: &[JointCommand]) -> Vec<WireTarget> {
        let mut out = vec![WireTarget::LIMP; self.wire_len()];
        for (i, w) in self.wire_targets(targets) {
            out[i] = w;
        }
        out
    }

    /// Canonical targets → (wire index, wire target) of each joint, in canonical order,
    /// without allocating.
    pub fn wire_targets<'a>(&'a self, targets: &'a [JointCommand]) -> impl Iterator<Item = (usize, WireTarget)> + 'a {
        self.joints
            .iter()
            .zip(targets)
            .map(|(j, c)| (j.wire_index, j.to_wire(c)))
    }

    /// Wire commands (wire order) → canonical commands (canonical order). Entries missing
    /// from `wire` are `None`.
    pub fn from_wire(&self, wire: &[WireTarget]) -> Vec<Option<JointCommand>> {
        self.joints
            .iter()
            .map(|j| wire.get(j.wire_index).map(|w| j.from_wire(w)))
            .collect()
    }

    /// Wire measurements (q, dq, tau in wire order) → canonical joint states.
    pub fn state_from_wire(&self, q: &[f32], dq: &[f32], tau: &[f32]) -> Vec<JointState> {
        let mut out = Vec::with_capacity(self.joints.len());
        self.state_from_wire_into(&mut out, |i| {
            Some((
                *q.get(i)?,
                dq.get(i).copied().unwrap_or(0.0),
                tau.get(i).copied().unwrap_or(0.0),
            ))
        });
        out
    }

    /// Wire measurements → canonical joint states in `out` (one per joint, its buffer
    /// reused): `wire(i)` is (q, dq, tau) at wire index `i`, `None` where nothing was measured
    /// (q NaN, dq and tau 0). Temperatures are `None`.
    pub fn state_from_wire_into(&self, out: &mut Vec<JointState>, wire: impl Fn(usize) -> Option<(f32, f32, f32)>) {
        out.clear();
        out.extend(self.joints.iter().map(|j| {
            let (q, dq, tau) = match wire(j.wire_index) {
                Some((q, dq, tau)) => (j.q_from_wire(q), j.rate_from_wire(dq), j.tau_from_wire(tau)),
                None => (f32::NAN, 0.0, 0.0),
            };
            JointState {
                q,
                dq,
                tau,
                temperature: None,
            }
        }));
    }

    /// Canonical joint states → wire (q, dq, tau) in wire order, for fronts that publish a
    /// device's state in another device's layout.
    pub fn state_to_wire(&self, states: &[JointState]) -> Vec<(f32, f32, f32)> {
        let mut out = vec![(0.0, 0.0, 0.0); self.wire_len()];
        for (j, s) in self.joints.iter().zip(states) {
            out[j.wire_index] = (j.q_to_wire(s.q), j.rate_to_wire(s.dq), j.tau_to_wire(s.tau));
        }
        out
    }

    /// Wire position limits of joint `id` (ordered min <= max).
    pub fn wire_limits(&self, id: JointId) -> Result<(f32, f32), MappingError> {
        let j = self.joint(id)?;
        let a = j.q_to_wire(j.limits.min);
        let b = j.q_to_wire(j.limits.max);
        Ok((a.min(b), a.max(b)))
    }

    /// The table with a profile's overrides applied. Unknown joint names are errors.
    pub fn with_overrides(mut self, o: &TableOverrides) -> Result<Self, MappingError> {
        self.max_step = o.max_step;
        if let Some(t) = o.motion_tolerance {
            self.motion.tolerance = t;
        }
        if let Some(c) = o.motion_contact {
            self.motion.contact = c;
        }
        if let Some(h) = o.motion_hold {
            self.motion.hold = h;
        }
        for (name, l) in &o.limits {
            self = self.with_limits(name, *l)?;
        }
        let n = self.joints.len();
        match &mut self.closure {
            ClosureMap::Postures { open, closed, .. } => {
                if let Some(p) = &o.open_posture {
                    *open = p.clone();
                }
                if let Some(p) = &o.closed_posture {
                    *closed = p.clone();
                }
                if open.len() != n || closed.len() != n {
                    return Err(MappingError::ClosureShape(self.kind, n, open.len().min(closed.len())));
                }
            }
            ClosureMap::Torque { open, closed } => {
                if let Some(v) = o.tau_open {
                    *open = v;
                }
                if let Some(v) = o.tau_closed {
                    *closed = v;
                }
            }
        }
        Ok(self)
    }

    /// Overrides one joint's limits.
    pub fn with_limits(mut self, name: &str, limits: Limits) -> Result<Self, MappingError> {
        let id = self.joint_by_name(name)?;
        self.joints[id.index()].limits = limits;
        Ok(self)
    }
}
