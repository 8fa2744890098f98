//! handgate as a ROS 2 node (docs/fronts.md, "ROS 2"): the namespace of its own topics, the
//! USER_DATA type hash of the ROS types it writes, and the `ros_discovery_info` graph message
//! naming node `<namespace>/handgate` with every reader and writer of its participant, as
//! rmw_cyclonedds publishes it (ROS 2 Iron and later: 16-byte GIDs).

use std::fmt;

use handgate_idl::ros2::{self, Gid_, NodeEntitiesInfo_, ParticipantEntitiesInfo_, RosType};
use handgate_idl::type_hash;

use crate::dds::{DdsError, Durability, EndpointOptions, Node, Qos, Writer};
use crate::discovery::{Guid, Role};

/// The ROS node name handgate announces.
pub const NODE_NAME: &str = "handgate";

/// Wall-clock time `t` as a ROS `builtin_interfaces/Time` (a time before the epoch is 0; the
/// seconds saturate at `i32::MAX`).
pub fn time(t: std::time::SystemTime) -> handgate_idl::ros2::Time_ {
    let d = t.duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    handgate_idl::ros2::Time_ {
        sec: d.as_secs().min(i32::MAX as u64) as i32,
        nanosec: d.subsec_nanos(),
    }
}

/// The prefix rmw puts before a ROS topic name to make its DDS topic name.
pub const TOPIC_PREFIX: &str = "rt/";

/// Why a namespace is not a valid ROS namespace.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NamespaceError {
    #[error("is empty (leave the key out for the root namespace)")]
    Empty,
    #[error("has an empty token (`//` or a trailing `/`)")]
    EmptyToken,
    #[error("token `{0}` starts with a digit")]
    LeadingDigit(String),
    #[error("token `{0}` has a character other than a-z, A-Z, 0-9 and `_`")]
    BadChar(String),
    #[error("is longer than {max} characters")]
    TooLong { max: usize },
}

/// A ROS namespace for handgate's own topics and node (`robot1`, `fleet/robot1`), validated
/// by the ROS naming rules (rmw `validate_namespace`: tokens of letters, digits and `_`, none
/// empty or starting with a digit). Stored without leading `/`; empty is the root namespace.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Namespace(String);

impl Namespace {
    /// The root namespace (`/`): topics as they are.
    pub fn root() -> Self {
        Self::default()
    }

    /// `s` with or without its leading `/` (`/robot1` and `robot1` are the same namespace).
    pub fn parse(s: &str) -> Result<Self, NamespaceError> {
        let body = s.strip_prefix('/').unwrap_or(s);
        if body.is_empty() {
            return Err(NamespaceError::Empty);
        }
        // The node's namespace travels in NodeEntitiesInfo's `string<=256`, with its `/`.
        if body.len() + 1 > ros2::NODE_NAME_MAX {
            return Err(NamespaceError::TooLong {
                max: ros2::NODE_NAME_MAX - 1,
            });
        }
        for token in body.split('/') {
            if token.is_empty() {
                return Err(NamespaceError::EmptyToken);
            }
            if token.starts_with(|c: char| c.is_ascii_digit()) {
                return Err(NamespaceError::LeadingDigit(token.into()));
            }
            if !token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(NamespaceError::BadChar(token.into()));
            }
        }
        Ok(Self(body.to_string()))
    }

    pub fn is_root(&self) -> bool {
        self.0.is_empty()
    }

    /// The namespace as ROS writes it: `/` or `/robot1`.
    pub fn ros(&self) -> String {
        format!("/{}", self.0)
    }

    /// DDS topic `topic` of one of handgate's own interfaces, inside this namespace: a ROS
    /// topic name relative to the node (`rt/joint_states` is `joint_states`) resolved in the
    /// node's namespace (`rt/robot1/joint_states`). A topic without the `rt/` prefix is not a
    /// ROS topic and stays as it is.
    pub fn topic(&self, topic: &str) -> String {
        match topic.strip_prefix(TOPIC_PREFIX) {
            Some(rest) if !self.is_root() => format!("{TOPIC_PREFIX}{}/{rest}", self.0),
            _ => topic.to_string(),
        }
    }
}

impl fmt::Display for Namespace {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.ros())
    }
}

/// USER_DATA of an endpoint of ROS type `T`: `typehash=RIHS01_...;` (REP-2011), so ROS 2
/// nodes (Iron and later) read its type hash.
pub fn user_data<T: RosType>() -> EndpointOptions {
    EndpointOptions::default().user_data(type_hash::user_data(T::DESCRIPTION))
}

/// The graph message for `participant` with one node, `ns`/[`NODE_NAME`], owning `endpoints`.
pub fn participant_info(participant: Guid, ns: &Namespace, endpoints: &[(Role, Guid)]) -> ParticipantEntitiesInfo_ {
    let gids = |role: Role| -> Vec<Gid_> {
        endpoints
            .iter()
            .filter(|(r, _)| *r == role)
            .map(|(_, g)| Gid_ { data: g.0 })
            .collect()
    };
    ParticipantEntitiesInfo_ {
        gid: Gid_ { data: participant.0 },
        node_entities_info_seq: vec![NodeEntitiesInfo_ {
            node_namespace: ns.ros(),
            node_name: NODE_NAME.into(),
            reader_gid_seq: gids(Role::Reader),
            writer_gid_seq: gids(Role::Writer),
        }],
    }
}

/// handgate's node on `ros_discovery_info`: reliable, transient-local, keep-last 1, as
/// rmw_cyclonedds writes it, so a ROS process that starts later still receives it.
pub struct Presence {
    writer: Writer<ParticipantEntitiesInfo_>,
    node: Node,
    namespace: Namespace,
    published: Option<u64>,
}

impl Presence {
    /// The `ros_discovery_info` writer on `node`'s participant (nothing published yet).
    pub fn new(node: &Node, namespace: Namespace) -> Result<Self, DdsError> {
        let writer = node.writer_with(
            ros2::DISCOVERY_INFO_TOPIC,
            Qos::Reliable { depth: 1 },
            &user_data::<ParticipantEntitiesInfo_>().durability(Durability::TransientLocal),
        )?;
        Ok(Self {
            writer,
            node: node.clone(),
            namespace,
            published: None,
        })
    }

    /// Publishes the node's readers and writers if they changed since the last call (the
    /// `ros_discovery_info` writer itself is the context's, not the node's, as in rmw).
    /// Returns whether it wrote.
    pub fn update(&mut self) -> Result<bool, DdsError> {
        let (mut endpoints, generation) = self.node.endpoints();
        if self.published == Some(generation) {
            return Ok(false);
        }
        let own = self.writer.guid();
        endpoints.retain(|(_, g)| *g != own);
        self.writer
            .write(participant_info(self.node.guid(), &self.namespace, &endpoints))?;
        self.published = Some(generation);
        Ok(true)
    }

    /// The `ros_discovery_info` writer's GUID.
    pub fn guid(&self) -> Guid {
        self.writer.guid()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn namespaces_follow_ros_rules() {
        assert_eq!(Namespace::parse("robot1").unwrap().ros(), "/robot1");
        assert_eq!(
            Namespace::parse("/robot1").unwrap(),
            Namespace::parse("robot1").unwrap()
        );
        assert_eq!(Namespace::parse("fleet/robot_1").unwrap().ros(), "/fleet/robot_1");
        assert_eq!(Namespace::parse(""), Err(NamespaceError::Empty));
        assert_eq!(Namespace::parse("/"), Err(NamespaceError::Empty));
        assert_eq!(Namespace::parse("a//b"), Err(NamespaceError::EmptyToken));
        assert_eq!(Namespace::parse("robot1/"), Err(NamespaceError::EmptyToken));
        assert_eq!(
            Namespace::parse("1robot"),
            Err(NamespaceError::LeadingDigit("1robot".into()))
        );
        assert_eq!(
            Namespace::parse("ro-bot"),
            Err(NamespaceError::BadChar("ro-bot".into()))
        );
        assert_eq!(Namespace::parse("rö"), Err(NamespaceError::BadChar("rö".into())));
        assert!(Namespace::parse(&"a".repeat(255)).is_ok());
        assert_eq!(
            Namespace::parse(&"a".repeat(256)),
            Err(NamespaceError::TooLong { max: 255 })
        );
        assert_eq!(Namespace::root().ros(), "/");
    }

    #[test]
    fn topics_resolve_relative_to_the_namespace() {
        let ns = Namespace::parse("robot1").unwrap();
        assert_eq!(ns.topic("rt/joint_states"), "rt/robot1/joint_states");
        assert_eq!(ns.topic("rt/handgate/status"), "rt/robot1/handgate/status");
        assert_eq!(ns.topic("rt/handgate/left/cmd"), "rt/robot1/handgate/left/cmd");
        assert_eq!(ns.topic("plain_dds"), "plain_dds");
        assert_eq!(Namespace::root().topic("rt/joint_states"), "rt/joint_states");
    }

    #[test]
    fn participant_info_lists_readers_and_writers() {
        let g = |n: u8| Guid([n; 16]);
        let ns = Namespace::parse("robot1").unwrap();
        let m = participant_info(
            g(1),
            &ns,
            &[(Role::Writer, g(2)), (Role::Reader, g(3)), (Role::Writer, g(4))],
        );
        assert_eq!(m.gid.data, [1; 16]);
        assert_eq!(m.node_entities_info_seq.len(), 1);
        let n = &m.node_entities_info_seq[0];
        assert_eq!(
            (n.node_namespace.as_str(), n.node_name.as_str()),
            ("/robot1", "handgate")
        );
        assert_eq!(n.reader_gid_seq, vec![Gid_ { data: [3; 16] }]);
        assert_eq!(n.writer_gid_seq, vec![Gid_ { data: [2; 16] }, Gid_ { data: [4; 16] }]);
    }
}
