//! A profile's `limits.max_step` reaches the device: profile text → validated profile → plan →
//! the device table the plan carries for the runtime (`plan.table`) → what a far command resolves to against a measured position.

mod support;

use handgate_adapters::model::{CommandBody, DeviceKind, JointCommand, JointState};
use support::plan_of;

fn profile(max_step: Option<f64>) -> String {
    let limits = max_step
        .map(|s| format!("limits = {{ max_step = {s} }}\n"))
        .unwrap_or_default();
    format!(
        r#"name = "max-step"
[[devices]]
name = "hand"
kind = "dex3"
side = "left"
backend = "emulator"
{limits}
[[devices]]
name = "grip"
kind = "dex1"
side = "right"
backend = "emulator"
{limits}
[[fronts]]
kind = "dex3"
device = "hand"
"#
    )
}

#[test]
fn profile_max_step_bounds_every_device_target_relative_to_measured() {
    let p = plan_of("max-step.toml", &profile(Some(0.07)));
    for d in &p.devices {
        assert_eq!(d.table.max_step, Some(0.07), "{}: plan", d.name);
        let t = (*d.table).clone();
        assert_eq!(t.max_step, Some(0.07), "{}: device table", d.name);
        // Every joint measured at 0.3 (canonical), commanded far closed.
        let n = t.joint_count();
        let meas = vec![
            JointState {
                q: 0.3,
                ..Default::default()
            };
            n
        ];
        let far = CommandBody::Joints(
            (0..n)
                .map(|i| {
                    (
                        handgate_adapters::model::JointId(i as u8),
                        JointCommand::hold(50.0, 1.0, 0.1),
                    )
                })
                .collect(),
        );
        let out = t.resolve(&far, None, &meas).unwrap();
        for (i, c) in out.iter().enumerate() {
            let expect = (0.3f32 + 0.07).min(t.joints[i].limits.max);
            assert!(
                (c.q - expect).abs() < 1e-6,
                "{} joint {i}: far command became {} with measured 0.3 and max_step 0.07",
                d.name,
                c.q
            );
        }
        if d.kind == DeviceKind::Dex3 {
            // And on the wire: left index_0 closes negative, 0.07 from the measured -0.3.
            let ix = t.joint_by_name("index_0").unwrap();
            let w = t.to_wire(&out)[t.joint(ix).unwrap().wire_index].q;
            assert!((w - (-0.37)).abs() < 1e-6, "wire {w}");
        }
    }
    // Without the key there is no per-step limit.
    let p = plan_of("no-max-step.toml", &profile(None));
    for d in &p.devices {
        assert_eq!(d.table.max_step, None);
    }
}
