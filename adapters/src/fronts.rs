//! The list of front kinds: every device kind's own fronts (`KindFactory::fronts`, registered
//! with the kind's line in [`crate::kinds::KINDS`]), then handgate's own interfaces, which
//! belong to no device kind. Adding a front for a new kind is part of that kind's folder
//! (docs/adapters.md, "Adding a front").

use crate::front::kind::FrontKind;
use crate::kinds::KINDS;

/// handgate's own fronts: its canonical messages, ROS 2 `joint_states` and ROS 2 JointState
/// commands.
pub const OWN: &[FrontKind] = &[
    FrontKind::Canonical,
    FrontKind::JointState,
    FrontKind::JointStateCommand,
];

/// Every front kind, in the order `handgate check` and errors list them: the device kinds'
/// (in [`KINDS`] order), then [`OWN`].
pub fn all() -> &'static [FrontKind] {
    static ALL: std::sync::OnceLock<Vec<FrontKind>> = std::sync::OnceLock::new();
    ALL.get_or_init(|| {
        KINDS
            .iter()
            .flat_map(|k| k.factory().fronts().iter().copied())
            .chain(OWN.iter().copied())
            .collect()
    })
}

/// (command, state) topics of handgate's own interface for `device` (`handgate send`).
pub fn own_topics(device: &str) -> (String, String) {
    crate::front::canonical::topics(device)
}
