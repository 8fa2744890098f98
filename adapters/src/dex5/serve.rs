//! The Dex5-1 service front (handgate serving the hand service's own
//! `rt/dex5/{left,right}/{cmd,state}`, docs/sources.md §7 "Dex5-1"), so an unmodified Dex5
//! client (xr_teleoperate's `Dex5_1_Controller`, the official SDK) drives any device: one front
//! per hand ([`OneHandFront`]); its codec is [`super::front`].

use handgate_idl::unitree_hg::{HandCmd_, HandState_};

use super::front::{decode_cmd, encode_state};
use super::table::{Conventions, WireConfig};
use crate::front::kind::{Front, FrontKind};
use crate::front::one_hand::{HandService, OneHandFront};
use crate::front::{FrontCommand, Rejection};
use crate::mapping::DeviceTable;
use crate::model::{DeviceKind, HandState, JointState, Side};

/// The Dex5-1 service's interface: unitree_hg `HandCmd_` (20 entries) in, `HandState_` out, in
/// the conventions a Dex5 client uses (docs/profiles.md, "Assumptions").
#[derive(Debug)]
pub struct Dex5Service(WireConfig);

impl Default for Dex5Service {
    /// The conventions a Dex5 client uses by default (xr_teleoperate's).
    fn default() -> Self {
        Dex5Service(WireConfig::of(&Conventions::default()))
    }
}

impl HandService for Dex5Service {
    const NAME: &'static str = "dex5";
    const SPEAKS: DeviceKind = DeviceKind::Dex5;
    /// The service's loop (an assumption, docs/profiles.md), whatever the device's rate; the
    /// service is assumed to hold its last command (no timeout).
    const STATE_HZ: f64 = super::SERVICE_HZ;
    type Cmd = HandCmd_;
    type State = HandState_;

    fn topics(side: Side) -> Option<(String, String)> {
        super::topics(side)
    }
    fn decode(&self, front: &DeviceTable, cmd: &HandCmd_) -> Result<FrontCommand, Rejection> {
        decode_cmd(cmd, front, &self.0)
    }
    fn encode(
        &self,
        front: &DeviceTable,
        joints: &[JointState],
        st: &HandState,
        _now: std::time::Instant,
    ) -> HandState_ {
        encode_state(front, joints, st)
    }
}

/// The Dex5-1 front.
pub type Dex5Front = OneHandFront<Dex5Service>;

impl FrontKind {
    /// The Dex5-1 hand service's DDS interface (`rt/dex5/{side}/*`, one hand per front).
    #[allow(non_upper_case_globals)]
    pub const Dex5: FrontKind = Dex5Front::KIND;
}
