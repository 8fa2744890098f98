//! What handgate's Robotiq device asks of the gripper each cycle, as a plain state machine
//! taking `now` ([`Driver`]): reset, activate (rACT 1 until gSTA 3), then move; a gripper
//! found reset (power cycle, another master) or in a major fault is reset and activated again.
//! The state a status image makes canonical is [`to_hand_state`].

use std::time::{Duration, Instant};

use super::regs::{Activation, Object, Request, Status, MA_PER_CURRENT_COUNT};
use crate::mapping::DeviceTable;
use crate::model::{faults, HandState, JointState};

/// How long an activation may take before it is started again (the 2F-140's is the longest,
/// a few seconds; assumed).
pub const ACTIVATION_TIMEOUT: Duration = Duration::from_secs(10);

/// Where the driver is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Writing rACT 0 (a reset: the rising edge that follows starts the activation).
    Reset,
    /// rACT 1 written at `since`, waiting for gSTA 3.
    Activating { since: Instant },
    /// Activated: moves are sent.
    Ready,
}

/// What changed, for the device's log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    None,
    ActivationStarted,
    Activated,
    ActivationTimedOut,
    /// The gripper was found reset while it was ready (power cycle, another master).
    FoundReset,
    /// A major fault (gFLT >= 0x0A): reset and activate again.
    MajorFault(u8),
}

/// The driver.
#[derive(Debug, Clone)]
pub struct Driver {
    phase: Phase,
    speed: u8,
    force: u8,
    /// The last position requested (kept while stopped, so gPR stays meaningful).
    last_position: u8,
}

impl Driver {
    /// A driver moving at rSP `speed` and rFR `force`.
    pub fn new(speed: u8, force: u8) -> Self {
        Driver {
            phase: Phase::Reset,
            speed,
            force,
            last_position: 0,
        }
    }

    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The request to send now: `target` the position to go to (`None`: stop where the
    /// fingers are, rGTO 0).
    pub fn request(&mut self, target: Option<u8>) -> Request {
        match self.phase {
            Phase::Reset => Request::default(),
            Phase::Activating { .. } => Request {
                act: true,
                ..Request::default()
            },
            Phase::Ready => {
                if let Some(p) = target {
                    self.last_position = p;
                }
                Request {
                    gto: target.is_some(),
                    ..Request::go(self.last_position, self.speed, self.force)
                }
            }
        }
    }

    /// The gripper answered `status` at `now` to the last request.
    pub fn observe(&mut self, now: Instant, status: &Status) -> Event {
        match self.phase {
            Phase::Reset if !status.act => {
                self.phase = Phase::Activating { since: now };
                Event::ActivationStarted
            }
            Phase::Reset => Event::None,
            Phase::Activating { .. } if status.activated() && status.act => {
                self.phase = Phase::Ready;
                self.last_position = status.position;
                Event::Activated
            }
            Phase::Activating { since } if now.saturating_duration_since(since) >= ACTIVATION_TIMEOUT => {
                self.phase = Phase::Reset;
                Event::ActivationTimedOut
            }
            Phase::Activating { .. } => Event::None,
            Phase::Ready if status.major_fault() => {
                self.phase = Phase::Reset;
                Event::MajorFault(status.fault)
            }
            Phase::Ready if !status.act || status.activation == Activation::Reset => {
                self.phase = Phase::Reset;
                Event::FoundReset
            }
            Phase::Ready => Event::None,
        }
    }
}

/// The canonical state of a gripper whose status is `s` (measured at `at`; `prev`: the last
/// one, for the velocity), into `st` (its buffers reused). Sets every field but the command
/// echo, freshness and the wall-clock time.
pub fn to_hand_state(
    table: &DeviceTable,
    s: &Status,
    at: Instant,
    prev: Option<(Status, Instant)>,
    st: &mut HandState,
) {
    let j = &table.joints[0];
    let dq = match prev {
        Some((p, t)) if at > t => {
            let dt = at.duration_since(t).as_secs_f32();
            j.rate_from_wire((f32::from(s.position) - f32::from(p.position)) / dt)
        }
        _ => 0.0,
    };
    // The motor current, A; its sign the way the fingers push (an object met opening pushes
    // them closed: negative).
    let amps = f32::from(s.current) * MA_PER_CURRENT_COUNT / 1000.0;
    let tau = if s.object == Object::ContactOpening {
        -amps
    } else {
        amps
    };
    st.joints.clear();
    st.joints.push(JointState {
        q: j.q_from_wire(f32::from(s.position)),
        dq,
        tau,
        temperature: None,
    });
    st.contact.clear();
    st.contact.push(s.gto && s.object.contact());
    st.closure = table.closure_of_state(&st.joints);
    let mut f = 0;
    // Minor faults (over-temperature) and major ones; the priority faults (0x05, 0x07) are
    // the activation's own sequence and 0x09 a silence handgate itself would have caused.
    if s.fault == super::regs::fault::OVER_TEMPERATURE || s.major_fault() {
        f |= faults::HARDWARE;
    }
    st.faults = f;
    st.measured_at = Some(at);
    st.mode = s.to_bytes()[0];
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robotiq::regs::fault;

    fn status(act: bool, activation: Activation) -> Status {
        Status {
            act,
            activation,
            ..Status::default()
        }
    }

    /// Reset, rACT 1 until gSTA 3, then moves; stop is rGTO 0 at the last position.
    #[test]
    fn resets_activates_then_moves() {
        let t = Instant::now();
        let mut d = Driver::new(200, 100);
        assert_eq!(d.request(Some(255)), Request::default());
        assert_eq!(
            d.observe(t, &status(false, Activation::Reset)),
            Event::ActivationStarted
        );
        let r = d.request(Some(255));
        assert!(r.act && !r.gto);
        assert_eq!(d.observe(t, &status(true, Activation::InProgress)), Event::None);
        let done = Status {
            position: 3,
            ..status(true, Activation::Completed)
        };
        assert_eq!(d.observe(t, &done), Event::Activated);
        assert_eq!(
            d.request(None),
            Request {
                gto: false,
                ..Request::go(3, 200, 100)
            }
        );
        assert_eq!(d.request(Some(255)), Request::go(255, 200, 100));
        assert_eq!(
            d.request(None),
            Request {
                gto: false,
                ..Request::go(255, 200, 100)
            }
        );
    }

    #[test]
    fn a_gripper_found_reset_or_faulted_is_activated_again() {
        let t = Instant::now();
        let mut d = Driver::new(255, 0);
        d.observe(t, &status(false, Activation::Reset));
        d.observe(t, &status(true, Activation::Completed));
        assert_eq!(d.phase(), Phase::Ready);
        assert_eq!(d.observe(t, &status(false, Activation::Reset)), Event::FoundReset);
        assert_eq!(d.phase(), Phase::Reset);
        d.observe(t, &status(false, Activation::Reset));
        d.observe(t, &status(true, Activation::Completed));
        let faulted = Status {
            fault: fault::OVERCURRENT,
            ..status(true, Activation::Completed)
        };
        assert_eq!(d.observe(t, &faulted), Event::MajorFault(fault::OVERCURRENT));
        // An activation that never completes is started again.
        d.observe(t, &status(false, Activation::Reset));
        assert_eq!(
            d.observe(t + ACTIVATION_TIMEOUT, &status(true, Activation::InProgress)),
            Event::ActivationTimedOut
        );
        assert_eq!(d.phase(), Phase::Reset);
    }
}
