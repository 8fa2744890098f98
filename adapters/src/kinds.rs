//! The one list of device kinds (the shape of probe-rs's `DRIVERS`). Adding a kind: its
//! folder (with its `Kind`), `pub mod` in `lib.rs`, and one line here
//! (docs/adapters.md, "Adding a device kind").

use crate::kind::DeviceKind;

/// Every device kind handgate knows, in the order `handgate check` and errors list them.
pub const KINDS: &[DeviceKind] = &[
    DeviceKind::Dex3,
    DeviceKind::Dex1,
    DeviceKind::Ezgripper,
    DeviceKind::HandSdk,
    DeviceKind::InspireDfx,
    DeviceKind::Brainco,
    DeviceKind::InspireFtp,
    DeviceKind::Dex5,
    DeviceKind::Robotiq,
    DeviceKind::InspireRh56,
    DeviceKind::Leap,
    DeviceKind::Rohand,
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Side;

    /// Each kind's pad layout names exactly the pads its state carries, in their order, and
    /// places them inside the drawing (mirrored for the left hand).
    #[test]
    fn pad_layouts_name_the_pads_the_state_carries_inside_the_unit_square() {
        let dex3: Vec<String> = (0..crate::dex3::PAD_COUNT)
            .map(|i| crate::model::Pad::dex3(i, [0.0; 12], [0.0; 12]).name)
            .collect();
        let ftp: Vec<String> = crate::inspire_ftp::front::SEGMENTS
            .iter()
            .map(|(n, _, _)| n.to_string())
            .collect();
        for kind in KINDS {
            let Some(layout) = kind.factory().pads() else {
                continue;
            };
            let names: Vec<String> = layout.right.iter().map(|p| p.name.to_string()).collect();
            let want = match kind.as_str() {
                "dex3" => &dex3,
                "inspire_ftp" => &ftp,
                other => panic!("{other} has pads: add what its state carries here"),
            };
            assert_eq!(&names, want, "{kind}");
            let shapes: Vec<(u16, u16)> = layout.right.iter().map(|p| (layout.shape)(p.name)).collect();
            let want_shapes: Vec<(u16, u16)> = match kind.as_str() {
                "dex3" => vec![(1, 12); crate::dex3::PAD_COUNT],
                _ => crate::inspire_ftp::front::SEGMENTS
                    .iter()
                    .map(|(_, r, c)| (*r, *c))
                    .collect(),
            };
            assert_eq!(shapes, want_shapes, "{kind}");
            for side in [Side::Left, Side::Right] {
                for p in layout.places(side) {
                    assert!(
                        p.x >= 0.0 && p.y >= 0.0 && p.x + p.w <= 1.0 + 1e-6 && p.y + p.h <= 1.0 + 1e-6,
                        "{kind} {side:?} {p:?}"
                    );
                }
            }
            let (l, r) = (layout.places(Side::Left), layout.places(Side::Right));
            assert!(
                (l[0].x + l[0].w - (1.0 - r[0].x)).abs() < 1e-6,
                "the left hand mirrors the right"
            );
        }
        let s = DeviceKind::Dex3.factory().pads().unwrap().scale;
        assert_eq!(s.normalise(crate::dex3::PRESS_NO_READING), -1.0);
        assert_eq!(s.normalise(crate::dex3::PRESS_VALID_MIN), 0.0);
        assert_eq!(s.normalise(1e9), 1.0);
        assert!((s.normalise(5.5 * crate::dex3::PRESS_VALID_MIN) - 0.5).abs() < 1e-6);
    }
}
