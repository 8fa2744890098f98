//! handgate's ROS 2 graph message on one participant (domain 206): what `Presence` lists,
//! when it writes, and that a reader joining later still gets it (transient-local).

use std::time::Duration;

use handgate_adapters::dds::{Durability, EndpointOptions, Node, Qos};
use handgate_adapters::discovery::Role;
use handgate_adapters::ros::{Namespace, Presence};
use handgate_idl::ros2::{JointState_, ParticipantEntitiesInfo_, DISCOVERY_INFO_TOPIC};

const DOMAIN: u32 = 206;
const WAIT: Duration = Duration::from_secs(10);

#[test]
fn presence_lists_the_nodes_endpoints_and_republishes_on_change() {
    let node = Node::new(DOMAIN, None).unwrap();
    let js = node
        .writer_with::<JointState_>(
            "rt/joint_states",
            Qos::Reliable { depth: 1 },
            &handgate_adapters::ros::user_data::<JointState_>(),
        )
        .unwrap();
    let cmd = node
        .reader::<JointState_>("rt/some/cmd", Qos::Reliable { depth: 4 })
        .unwrap();
    let mut presence = Presence::new(&node, Namespace::parse("robot1").unwrap()).unwrap();
    assert!(presence.update().unwrap(), "first update writes");
    assert!(!presence.update().unwrap(), "nothing changed: nothing written");

    // A reader made after the sample was written still receives it (transient-local).
    let peer = Node::new(DOMAIN, None).unwrap();
    let r = peer
        .reader_with::<ParticipantEntitiesInfo_>(
            DISCOVERY_INFO_TOPIC,
            Qos::Reliable { depth: 1 },
            &EndpointOptions::default().durability(Durability::TransientLocal),
        )
        .unwrap();
    let m = r.wait_take(WAIT).unwrap().pop().unwrap();
    assert_eq!(m.gid.data, node.guid().0);
    let n = &m.node_entities_info_seq[0];
    assert_eq!(
        (n.node_namespace.as_str(), n.node_name.as_str()),
        ("/robot1", "handgate")
    );
    let writers: Vec<[u8; 16]> = n.writer_gid_seq.iter().map(|g| g.data).collect();
    let readers: Vec<[u8; 16]> = n.reader_gid_seq.iter().map(|g| g.data).collect();
    assert_eq!(writers, vec![js.guid().0], "the graph writer itself is not the node's");
    assert_eq!(readers, vec![cmd.guid().0]);
    assert_ne!(presence.guid(), js.guid());
    let (listed, _) = node.endpoints();
    assert!(listed.contains(&(Role::Writer, presence.guid())));

    // An endpoint goes away: the node is republished without it.
    drop(cmd);
    assert!(presence.update().unwrap());
    let m = r.wait_take(WAIT).unwrap().pop().unwrap();
    assert!(m.node_entities_info_seq[0].reader_gid_seq.is_empty());
    assert_eq!(m.node_entities_info_seq[0].writer_gid_seq.len(), 1);
}
