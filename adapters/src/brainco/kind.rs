//! The BrainCo Revo2 as a registered device kind: a client of `brainco_hand_service` over DDS,
//! or on the emulator backend of the service's emulator on private topics, through the very
//! same codec ([`ServiceHand`]).

use super::adapter::BraincoCodec;
use super::config::BraincoProfile;
use super::emulator::{BraincoConfig, BraincoCore, BRAINCO_DEFAULT_HZ, BRAINCO_NOISE};
use super::table::JOINTS;
use crate::front::kind::FrontKind;
use crate::kind::{DeviceKind, KindFacts};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::service_client::ServiceHand;
use crate::sim::Noise;

impl DeviceKind {
    /// BrainCo Revo2 hand (through `brainco_hand_service` over DDS).
    #[allow(non_upper_case_globals)]
    pub const Brainco: DeviceKind = DeviceKind::of(&BraincoKind);
}

/// The BrainCo Revo2.
#[derive(Debug, Clone, Copy)]
pub struct BraincoKind;

impl ServiceHand for BraincoKind {
    /// The service's loop (docs/sources.md §7); its own interface `rt/brainco/{side}/*`.
    const FACTS: KindFacts = KindFacts::hand_service("brainco", &JOINTS, BRAINCO_DEFAULT_HZ, &[FrontKind::Brainco]);
    const SERVICE: &'static str = "brainco_hand_service";
    const NOISE: Noise = BRAINCO_NOISE;
    type Config = BraincoProfile;
    /// The finger speed sent in every entry's `dq`.
    type Wire = f32;
    type Codec = BraincoCodec;
    type Emulate = ();
    type Core = BraincoCore;

    fn table(side: Side, _config: &BraincoProfile) -> DeviceTable {
        super::table::table(side)
    }
    fn wire(config: &BraincoProfile) -> f32 {
        config.keys().speed()
    }
    fn codec(speed: f32) -> BraincoCodec {
        BraincoCodec::new(speed)
    }
    fn service(side: Side, _speed: &f32, noise: Noise) -> BraincoConfig {
        BraincoConfig {
            noise,
            ..BraincoConfig::new(side)
        }
    }
}
