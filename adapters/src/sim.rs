//! A simple physical joint model shared by every emulator: one rigid joint driven by the
//! motor law real Unitree motors run (`tau = kp*(q_des-q) + kd*(dq_des-dq) + tau_ff`), with
//! torque saturation, viscous friction, hard position stops and an optional object that the
//! joint closes on (contact stiffness), so grasp, pressure and current can be emulated.

/// Per-motor setpoint in the device's own frame and units (rad, rad/s, N*m, N*m/rad, N*m*s/rad).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotorTarget {
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
    pub kp: f32,
    pub kd: f32,
}

impl MotorTarget {
    /// Zero gains and torque: the motor applies nothing (limp).
    pub const LIMP: MotorTarget = MotorTarget {
        q: 0.0,
        dq: 0.0,
        tau: 0.0,
        kp: 0.0,
        kd: 0.0,
    };
}

/// Physical parameters of an emulated joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointParams {
    /// Reflected inertia, kg*m^2.
    pub inertia: f32,
    /// Viscous friction, N*m*s/rad.
    pub friction: f32,
    /// Torque saturation, N*m.
    pub tau_max: f32,
    /// Hard stops, rad.
    pub q_min: f32,
    pub q_max: f32,
}

impl JointParams {
    /// A Dex3-1 finger joint: small inertia, ~1.5 N*m peak (F-1515-214).
    pub fn dex3_finger(q_min: f32, q_max: f32) -> Self {
        Self {
            inertia: 2.0e-4,
            friction: 0.02,
            tau_max: 1.5,
            q_min,
            q_max,
        }
    }
}

/// An object in the joint's path: from `at` onwards (in the closing direction `dir`, +1 or
/// -1) it pushes back with `stiffness` N*m/rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    pub at: f32,
    pub dir: f32,
    pub stiffness: f32,
}

/// One emulated joint.
#[derive(Debug, Clone, PartialEq)]
pub struct JointModel {
    pub params: JointParams,
    pub q: f32,
    pub dq: f32,
    /// Torque the motor applied in the last step (what a motor reports as tau_est).
    pub tau: f32,
    /// Contact torque from the object in the last step (>= 0).
    pub contact_tau: f32,
    pub contact: Option<Contact>,
}

impl JointModel {
    pub fn new(params: JointParams, q0: f32) -> Self {
        Self {
            params,
            q: q0.clamp(params.q_min, params.q_max),
            dq: 0.0,
            tau: 0.0,
            contact_tau: 0.0,
            contact: None,
        }
    }

    /// Advances the joint by `dt` seconds under `target`. Non-finite targets are treated as limp.
    pub fn step(&mut self, target: &MotorTarget, dt: f32) {
        let t = if [target.q, target.dq, target.tau, target.kp, target.kd]
            .iter()
            .all(|v| v.is_finite())
        {
            *target
        } else {
            MotorTarget::LIMP
        };
        let p = self.params;
        let motor = (t.kp * (t.q - self.q) + t.kd * (t.dq - self.dq) + t.tau).clamp(-p.tau_max, p.tau_max);
        self.tau = motor;
        self.contact_tau = 0.0;
        let mut external = 0.0;
        if let Some(c) = self.contact {
            let pen = (self.q - c.at) * c.dir;
            if pen > 0.0 {
                self.contact_tau = c.stiffness * pen;
                external = -c.dir * self.contact_tau;
            }
        }
        // Semi-implicit Euler in sub-steps small enough for stiff gains to stay stable.
        let n = ((dt / 1.0e-4).ceil() as usize).clamp(1, 100);
        let h = dt / n as f32;
        for _ in 0..n {
            let motor = (t.kp * (t.q - self.q) + t.kd * (t.dq - self.dq) + t.tau).clamp(-p.tau_max, p.tau_max);
            let acc = (motor + external - p.friction * self.dq) / p.inertia;
            self.dq += acc * h;
            // Damping implied by kd and friction can make explicit steps unstable at high gains:
            // bound |dq| by what the torque limit could physically produce.
            let vmax = 50.0;
            self.dq = self.dq.clamp(-vmax, vmax);
            self.q += self.dq * h;
            if self.q <= p.q_min {
                self.q = p.q_min;
                self.dq = self.dq.max(0.0);
            } else if self.q >= p.q_max {
                self.q = p.q_max;
                self.dq = self.dq.min(0.0);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pd_reaches_target() {
        let mut j = JointModel::new(JointParams::dex3_finger(-1.6, 1.6), 0.0);
        let t = MotorTarget {
            q: 1.0,
            kp: 1.5,
            kd: 0.1,
            ..Default::default()
        };
        for _ in 0..2000 {
            j.step(&t, 0.001);
        }
        assert!((j.q - 1.0).abs() < 0.02, "q = {}", j.q);
    }

    #[test]
    fn stops_hold_and_limp_drifts_to_rest() {
        let mut j = JointModel::new(JointParams::dex3_finger(0.0, 0.5), 0.2);
        let t = MotorTarget {
            q: 3.0,
            kp: 5.0,
            kd: 0.1,
            ..Default::default()
        };
        for _ in 0..2000 {
            j.step(&t, 0.001);
        }
        assert_eq!(j.q, 0.5);
        for _ in 0..2000 {
            j.step(&MotorTarget::LIMP, 0.001);
        }
        assert!(j.dq.abs() < 1e-3);
    }

    #[test]
    fn contact_stops_closing_and_reports_force() {
        let mut j = JointModel::new(JointParams::dex3_finger(-1.6, 1.6), 0.0);
        j.contact = Some(Contact {
            at: 0.5,
            dir: 1.0,
            stiffness: 20.0,
        });
        let t = MotorTarget {
            q: 1.5,
            kp: 1.0,
            kd: 0.05,
            ..Default::default()
        };
        for _ in 0..3000 {
            j.step(&t, 0.001);
        }
        assert!(j.q > 0.5 && j.q < 0.6, "q = {}", j.q);
        assert!(j.contact_tau > 0.5);
    }

    #[test]
    fn non_finite_target_is_limp() {
        let mut j = JointModel::new(JointParams::dex3_finger(-1.6, 1.6), 0.3);
        j.step(
            &MotorTarget {
                q: f32::NAN,
                kp: 1.0,
                ..Default::default()
            },
            0.001,
        );
        assert!(j.q.is_finite());
        assert_eq!(j.tau, 0.0);
    }
}
