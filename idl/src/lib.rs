//! Wire types only: the DDS messages real Unitree systems exchange with hands and grippers,
//! byte-for-byte as unitree_sdk2 (CycloneDDS idlc 0.10.2, XCDR1, FINAL, keyless) lays them out,
//! plus handgate's own canonical messages (`idl/handgate.idl`), the ROS 2 `JointState` (with the
//! REP-2011 type hashes of the ROS types, [`type_hash`]), the ROS 2 graph message and the
//! Inspire FTP hand's own messages (`inspire::`, `idl/inspire.idl`).
//!
//! Field order is wire order. Fixed arrays are Rust arrays, IDL sequences are `Vec`s.
//! Every type implements cyclonedds-rs [`TopicType`] with its exact DDS type name, e.g.
//! `unitree_hg::msg::dds_::HandCmd_` (the Python SDK spells it with dots; on the wire it is `::`).
//!
//! Sources: unitree_sdk2 `include/unitree/idl/{hg,go2}/*.hpp`, unitree_sdk2_python
//! `unitree_sdk2py/idl/`; see `docs/wire-types.md` for which topics and systems use each.

pub mod cdr_codec;
pub mod handgate;
pub mod inspire;
pub mod layout;
pub mod ros2;
pub mod ros2msg;
pub mod type_hash;
pub mod unitree_go;
pub mod unitree_hg;
pub mod xcdr2;

pub use cdr_codec::{from_cdr, from_cdr_body, to_cdr_be, to_cdr_le, CdrError};
pub use cyclonedds_rs::TopicType;

/// Implements [`TopicType`] for a keyless type with an explicit DDS type name (and, in braces,
/// further `TopicType` methods: a type that encodes itself, `own_encoding`).
macro_rules! keyless_topic_type {
    ($ty:ty, $name:literal) => {
        $crate::keyless_topic_type!($ty, $name, {});
    };
    ($ty:ty, $name:literal, { $($extra:item)* }) => {
        impl cyclonedds_rs::TopicType for $ty {
            fn typename() -> std::ffi::CString {
                std::ffi::CString::new($name).expect("static type name has no NUL")
            }
            fn has_key() -> bool {
                false
            }
            fn key_cdr(&self) -> Vec<u8> {
                Vec::new()
            }
            fn force_md5_keyhash() -> bool {
                false
            }
            $($extra)*
        }
        impl $crate::DdsTypeName for $ty {
            const DDS_TYPE_NAME: &'static str = $name;
        }
    };
}
pub(crate) use keyless_topic_type;

/// The exact DDS type name of a wire type, as a constant (the same string
/// [`TopicType::typename`] returns).
pub trait DdsTypeName {
    const DDS_TYPE_NAME: &'static str;
}
