//! The wire types a recording can carry: for each, its `ros2msg` schema
//! ([`handgate_idl::ros2msg`]) and how to subscribe to it (taking each sample as
//! little-endian CDR with its source timestamp) and to publish recorded CDR back onto DDS.

use handgate_adapters::dds::{DdsError, Node, Qos, Reader, Writer};
use handgate_idl::ros2msg::{self, MsgSchema};
use handgate_idl::{from_cdr, handgate, inspire, ros2, to_cdr_le, unitree_go, unitree_hg, DdsTypeName, TopicType};
use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::RecordError;

/// Samples taken from one subscribed topic.
pub trait Source: Send {
    /// Appends every available sample as (source timestamp ns, CDR with header).
    fn take(&mut self, out: &mut Vec<(i64, Vec<u8>)>) -> usize;
    /// Writers currently matched.
    fn matched(&self) -> u32;
}

/// Publishes recorded CDR messages on one topic.
pub trait Sink: Send {
    fn publish(&mut self, cdr: &[u8]) -> Result<(), RecordError>;
    /// Readers currently matched.
    fn matched(&self) -> u32;
}

struct TypedSource<T: TopicType> {
    reader: Reader<T>,
    scratch: Vec<(T, i64)>,
}

impl<T> Source for TypedSource<T>
where
    T: TopicType + Serialize + Clone + Send + 'static,
{
    fn take(&mut self, out: &mut Vec<(i64, Vec<u8>)>) -> usize {
        self.scratch.clear();
        self.reader.take_stamped(&mut self.scratch);
        let mut n = 0;
        for (sample, stamp) in self.scratch.drain(..) {
            // Re-encoded from the decoded sample: cyclonedds-rs does not keep a received
            // sample's bytes or byte order, and the values are the same.
            if let Ok(cdr) = to_cdr_le(&sample) {
                out.push((stamp, cdr));
                n += 1;
            }
        }
        n
    }

    fn matched(&self) -> u32 {
        self.reader.matched()
    }
}

struct TypedSink<T: TopicType> {
    writer: Writer<T>,
}

impl<T> Sink for TypedSink<T>
where
    T: TopicType + DeserializeOwned + Send + 'static,
{
    fn publish(&mut self, cdr: &[u8]) -> Result<(), RecordError> {
        let sample: T =
            from_cdr(cdr).map_err(|e| RecordError::Decode(self.writer.topic().to_string(), e.to_string()))?;
        self.writer.write(sample)?;
        Ok(())
    }

    fn matched(&self) -> u32 {
        self.writer.matched()
    }
}

/// Subscribes a topic as one wire type.
type SubscribeFn = fn(&Node, &str, Qos) -> Result<Box<dyn Source>, DdsError>;
/// Makes a writer of one wire type.
type PublisherFn = fn(&Node, &str, Qos) -> Result<Box<dyn Sink>, DdsError>;

/// One recordable wire type.
#[derive(Debug, Clone, Copy)]
pub struct WireType {
    pub schema: &'static MsgSchema,
    subscribe: SubscribeFn,
    publisher: PublisherFn,
}

impl WireType {
    /// A reader of this type on `topic`.
    pub fn subscribe(&self, node: &Node, topic: &str, qos: Qos) -> Result<Box<dyn Source>, DdsError> {
        (self.subscribe)(node, topic, qos)
    }

    /// A writer of this type on `topic`.
    pub fn publisher(&self, node: &Node, topic: &str, qos: Qos) -> Result<Box<dyn Sink>, DdsError> {
        (self.publisher)(node, topic, qos)
    }
}

fn subscribe<T>(node: &Node, topic: &str, qos: Qos) -> Result<Box<dyn Source>, DdsError>
where
    T: TopicType + Serialize + Clone + Send + 'static,
{
    Ok(Box::new(TypedSource::<T> {
        reader: node.reader::<T>(topic, qos)?,
        scratch: Vec::new(),
    }))
}

fn publisher<T>(node: &Node, topic: &str, qos: Qos) -> Result<Box<dyn Sink>, DdsError>
where
    T: TopicType + DeserializeOwned + Send + 'static,
{
    Ok(Box::new(TypedSink::<T> {
        writer: node.writer::<T>(topic, qos)?,
    }))
}

macro_rules! wire_types {
    ($($ty:ty),* $(,)?) => {
        /// The DDS type name and entry of every recordable type.
        fn table() -> &'static [(&'static str, SubscribeFn, PublisherFn)] {
            &[$((<$ty as DdsTypeName>::DDS_TYPE_NAME, subscribe::<$ty>, publisher::<$ty>)),*]
        }
    };
}

wire_types!(
    unitree_hg::HandCmd_,
    unitree_hg::HandState_,
    unitree_go::MotorCmds_,
    unitree_go::MotorStates_,
    handgate::HandCmd_,
    handgate::HandState_,
    handgate::GatewayStatus_,
    ros2::JointState_,
    ros2::DiagnosticArray_,
    ros2::HardwareStatus_,
    inspire::InspireHandCtrl,
    inspire::InspireHandState,
    inspire::InspireHandTouch,
);

/// The recordable type registered as `dds_type`, if any.
pub fn wire_type(dds_type: &str) -> Option<WireType> {
    let (name, subscribe, publisher) = table().iter().find(|(n, _, _)| *n == dds_type)?;
    Some(WireType {
        schema: ros2msg::schema(name)?,
        subscribe: *subscribe,
        publisher: *publisher,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_recordable_type_has_a_schema_and_every_schema_a_type() {
        for (name, _, _) in table() {
            assert!(wire_type(name).is_some(), "{name}");
        }
        for s in ros2msg::SCHEMAS {
            assert!(table().iter().any(|(n, _, _)| *n == s.dds_type), "{}", s.dds_type);
        }
    }
}
