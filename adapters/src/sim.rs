//! A simple physical joint model shared by every emulator: one rigid joint driven by the
//! motor law real Unitree motors run (`tau = kp*(q_des-q) + kd*(dq_des-dq) + tau_ff`), with
//! torque saturation, viscous friction, hard position stops, an optional object that the
//! joint closes on (contact stiffness), so grasp, pressure and current can be emulated, and an
//! optional constant load ([`JointModel::load`]).
//!
//! **Sag under a constant load.** A position servo of finite stiffness `kp` holding a joint
//! against a constant load (gravity on a finger, a spring, the weight of what it holds)
//! settles `load / kp` short of its target, and stays there: a fixed target under a fixed load
//! is a fixed position. A controller that re-took its target from that measurement every cycle
//! would move the target by the sag every cycle, and the joint would creep without end at
//! (sag reached per cycle) × (cycle rate) (docs/adapters.md, "Holds"). [`JointModel::load`]
//! gives the PD joints this load; the emulators whose fingers follow a first-order position
//! loop instead of a torque law (Inspire DFX, Inspire FTP, BrainCo) take the servo's
//! steady-state error directly, as a [`Sag`].
//!
//! Also the measurement side every emulator shares: [`Noise`] (per-kind standard deviations
//! of position, velocity and torque noise plus a seed) and [`Sensor`], which reads a
//! [`JointModel`] the way an encoder and a current sensor would, from a small seeded PRNG
//! ([`Prng`], SplitMix64) so runs with the same seed report the same noise.

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
    /// A constant external torque on the joint, N*m, positive toward +q (0: none). Under a
    /// PD target it is the steady-state error `load / kp` (module docs, "Sag").
    pub load: f32,
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
            load: 0.0,
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
        let mut external = if self.load.is_finite() { self.load } else { 0.0 };
        if let Some(c) = self.contact {
            let pen = (self.q - c.at) * c.dir;
            if pen > 0.0 {
                self.contact_tau = c.stiffness * pen;
                external -= c.dir * self.contact_tau;
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

/// The steady-state error of a first-order position servo under a constant load, in the
/// device's own position units, signed (module docs, "Sag"): the servo settles at
/// `target + sag` instead of `target`. For a servo of stiffness `kp` under a load `tau`,
/// [`Sag::of`] gives `tau / kp`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sag(pub f32);

impl Sag {
    /// No load.
    pub const NONE: Sag = Sag(0.0);

    /// The sag of a servo of stiffness `kp` (torque per position unit) under a constant load
    /// `tau` (positive toward +q); none without stiffness.
    pub fn of(tau: f32, kp: f32) -> Self {
        if kp > 0.0 && (tau / kp).is_finite() {
            Sag(tau / kp)
        } else {
            Sag::NONE
        }
    }

    /// Where the servo settles when it holds `target` (a non-finite sag is none).
    pub fn goal(self, target: f32) -> f32 {
        if self.0.is_finite() {
            target + self.0
        } else {
            target
        }
    }
}

/// SplitMix64 (Steele, Lea, Flood 2014): 64 bits of state, a few operations per draw, good
/// enough statistics for measurement noise, and deterministic for a given seed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Prng(u64);

impl Prng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [-1, 1).
    pub fn uniform(&mut self) -> f32 {
        // 24 random bits: every value is exact in f32.
        let u = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        2.0 * u - 1.0
    }

    /// Zero mean, unit standard deviation, bounded to [-3, 3]: the sum of three uniforms on
    /// [-1, 1) (Irwin-Hall; variance 3 * 1/3 = 1). Close to Gaussian without a logarithm, and
    /// bounded, so a reading never strays more than 3 standard deviations.
    pub fn normalish(&mut self) -> f32 {
        self.uniform() + self.uniform() + self.uniform()
    }
}

/// Largest standard deviations a [`Noise`] accepts: anything larger is not measurement noise
/// of a joint encoder or current sensor any more.
pub const NOISE_MAX_Q: f32 = 0.05;
pub const NOISE_MAX_DQ: f32 = 5.0;
pub const NOISE_MAX_TAU: f32 = 0.5;

/// Measurement noise of an emulated device: standard deviations in the device's own units
/// (rad, rad/s, N*m), and the PRNG seed. Each kind's default figures live with the kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
    pub seed: u64,
}

impl Noise {
    /// No noise: readings are the model's exact values.
    pub const OFF: Noise = Noise {
        q: 0.0,
        dq: 0.0,
        tau: 0.0,
        seed: 0,
    };

    /// The default seed (fixed, so runs and tests are deterministic).
    pub const DEFAULT_SEED: u64 = 0x6861_6E64_6761_7465; // "handgate"

    pub fn is_off(&self) -> bool {
        self.q == 0.0 && self.dq == 0.0 && self.tau == 0.0
    }

    /// The same figures with another seed.
    pub fn with_seed(self, seed: u64) -> Self {
        Self { seed, ..self }
    }

    /// `Err` with a reason unless every deviation is finite, >= 0 and within the `NOISE_MAX_*`
    /// bounds.
    pub fn validate(&self) -> Result<(), String> {
        for (what, v, max) in [
            ("position", self.q, NOISE_MAX_Q),
            ("velocity", self.dq, NOISE_MAX_DQ),
            ("torque", self.tau, NOISE_MAX_TAU),
        ] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(format!("{what} noise must be between 0 and {max}, got {v}"));
            }
        }
        Ok(())
    }
}

/// One reading of a joint: what the device reports.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Reading {
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
}

/// Reads joints with a device's measurement noise. One per emulated device; the draws come
/// in reading order, so the same seed and the same sequence of readings give the same noise.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    noise: Noise,
    rng: Prng,
}

impl Sensor {
    pub fn new(noise: Noise) -> Self {
        Self {
            noise,
            rng: Prng::new(noise.seed),
        }
    }

    pub fn noise(&self) -> Noise {
        self.noise
    }

    /// Back to the first draw of the seed (a power cycle).
    pub fn reset(&mut self) {
        self.rng = Prng::new(self.noise.seed);
    }

    /// `v` plus noise of standard deviation `sd` (no draw when `sd` is 0).
    pub fn add(&mut self, v: f32, sd: f32) -> f32 {
        if sd == 0.0 {
            v
        } else {
            v + sd * self.rng.normalish()
        }
    }

    /// The joint's position, velocity and torque as the device measures them.
    pub fn read(&mut self, j: &JointModel) -> Reading {
        let n = self.noise;
        Reading {
            q: self.add(j.q, n.q),
            dq: self.add(j.dq, n.dq),
            tau: self.add(j.tau, n.tau),
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

    /// A constant load moves a held joint once, by `load / kp`, and never again: a fixed target
    /// under a fixed load is a fixed position.
    #[test]
    fn a_constant_load_sags_a_held_joint_by_load_over_kp_and_no_further() {
        let mut j = JointModel::new(JointParams::dex3_finger(-1.6, 1.6), 0.5);
        j.load = -0.05;
        let t = MotorTarget {
            q: 0.5,
            kp: 2.0,
            kd: 0.1,
            ..Default::default()
        };
        for _ in 0..3000 {
            j.step(&t, 0.001);
        }
        let settled = j.q;
        assert!((settled - (0.5 - 0.025)).abs() < 1e-4, "q = {settled}");
        for _ in 0..60_000 {
            j.step(&t, 0.001);
        }
        assert!((j.q - settled).abs() < 1e-6, "{} then {}", settled, j.q);
        assert_eq!(Sag::of(-0.05, 2.0), Sag(-0.025));
        assert_eq!(Sag::of(1.0, 0.0), Sag::NONE);
        assert_eq!(Sag(-0.025).goal(0.5), 0.475);
        assert_eq!(Sag(f32::NAN).goal(0.5), 0.5);
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

    #[test]
    fn prng_is_deterministic_and_normalish_is_bounded_with_unit_variance() {
        let mut a = Prng::new(7);
        let mut b = Prng::new(7);
        let xs: Vec<f32> = (0..20_000).map(|_| a.normalish()).collect();
        let ys: Vec<f32> = (0..20_000).map(|_| b.normalish()).collect();
        assert_eq!(xs, ys);
        assert!(xs.iter().all(|x| (-3.0..=3.0).contains(x)));
        let mean = xs.iter().sum::<f32>() / xs.len() as f32;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f32>() / xs.len() as f32;
        assert!(mean.abs() < 0.05, "mean {mean}");
        assert!((var - 1.0).abs() < 0.05, "variance {var}");
        let mut c = Prng::new(8);
        assert_ne!(xs[..8], (0..8).map(|_| c.normalish()).collect::<Vec<_>>()[..]);
    }

    #[test]
    fn sensor_off_reads_exact_values_and_on_reads_near_them() {
        let mut j = JointModel::new(JointParams::dex3_finger(-1.6, 1.6), 0.3);
        j.dq = 0.1;
        j.tau = 0.2;
        let mut off = Sensor::new(Noise::OFF);
        assert_eq!(
            off.read(&j),
            Reading {
                q: 0.3,
                dq: 0.1,
                tau: 0.2
            }
        );
        let noise = Noise {
            q: 1e-3,
            dq: 1e-2,
            tau: 1e-3,
            seed: 1,
        };
        let mut on = Sensor::new(noise);
        let r = on.read(&j);
        assert_ne!(r.q, 0.3);
        assert!((r.q - 0.3).abs() <= 3.0 * noise.q + 1e-6);
        assert!((r.dq - 0.1).abs() <= 3.0 * noise.dq + 1e-6);
        assert!((r.tau - 0.2).abs() <= 3.0 * noise.tau + 1e-6);
        on.reset();
        assert_eq!(on.read(&j), r);
    }

    #[test]
    fn noise_validation() {
        assert!(Noise::OFF.validate().is_ok());
        let bad = |q, dq, tau| Noise { q, dq, tau, seed: 0 }.validate().is_err();
        assert!(bad(-1e-3, 0.0, 0.0));
        assert!(bad(f32::NAN, 0.0, 0.0));
        assert!(bad(0.0, NOISE_MAX_DQ * 2.0, 0.0));
        assert!(bad(0.0, 0.0, f32::INFINITY));
    }
}
