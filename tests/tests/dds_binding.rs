//! The DDS binding: cyclonedds-rs 0.6.5's serdata callbacks (patched in `vendor/cyclonedds-rs`,
//! docs/sources.md §8 "The DDS binding") called exactly as CycloneDDS 0.10.2 calls them, with
//! the arguments its write path passes (`nn_xmsg_serdata` asks `to_ser_ref` for
//! `[offset, offset + align4(len))`; a retransmitted or very large sample is asked for in
//! fragments of `FragmentSize`, 1344 B by default), into buffers with guard bytes after them.
//! Each of these fails on the crate as published (a wrong size, wrong bytes, an overrun guard,
//! `false`, or an abort from a panic inside an `extern "C"` callback).
//!
//! The expected wire bytes are what CycloneDDS's own serialiser produces for a sample: the
//! 4-byte encapsulation header, the CDR payload (`handgate_idl::to_cdr_be`, the same encoding
//! cyclonedds-rs writes; `golden_bytes.rs` checks handgate's encoder against unitree_sdk2py's
//! bytes), then zero bytes up to a multiple of 4, their number in the low two bits of the
//! header's options (CycloneDDS 0.10.2 `dds_ostream_add_to_serdata_default`).
//!
//! Below them, the binding on live domains (docs/development.md): the QoS objects of endpoints
//! (217; fails on the published crate, which leaks them), and every wire type through
//! unitree_sdk2py both ways (218; passes on the published crate too: it is the run
//! `scripts/valgrind.sh wire` checks under memcheck).

use std::ffi::{c_void, CStr};
use std::marker::PhantomData;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use cyclonedds_rs::serdes::{Sample, SerType};
use cyclonedds_sys::{dds_qos_t, ddsi_serdata, ddsi_serdata_ops, ddsi_serdata_removeref, ddsi_sertype, iovec};
use handgate_adapters::dds::Node;
use handgate_adapters::dds::{EndpointOptions, Qos};
use handgate_idl::{from_cdr, handgate, inspire, ros2, to_cdr_be, to_cdr_le, unitree_go, unitree_hg, TopicType};
use handgate_tests::{fixture, from_plain_json, interop_interface, stream_until, FromPlain, PyProcess};
use serde::Serialize;

const SDK_KEY: u32 = cyclonedds_sys::ddsi_serdata_kind_SDK_KEY;
const SDK_DATA: u32 = cyclonedds_sys::ddsi_serdata_kind_SDK_DATA;
/// CycloneDDS's default `FragmentSize`.
const FRAGMENT: usize = 1344;
/// A byte the callbacks must never write (guard) and a buffer filler they must overwrite.
const GUARD: u8 = 0xA5;

/// What CycloneDDS sends for `value`: header with the padding count, payload, zero padding.
fn wire_bytes<T: Serialize>(value: &T) -> Vec<u8> {
    let mut b = to_cdr_be(value).expect("encodes");
    let pad = (4 - b.len() % 4) % 4;
    b[3] = pad as u8;
    b.resize(b.len() + pad, 0);
    b
}

fn value_of<T: FromPlain>(module: &str, type_name: &str, case: &str) -> T {
    let f = fixture(module, type_name, case).unwrap_or_else(|e| panic!("fixture {module}/{type_name}/{case}: {e}"));
    f.value_as::<T>()
        .unwrap_or_else(|e| panic!("fixture {}: {e}", f.label()))
}

/// A sertype of `T` made by cyclonedds-rs, with its serdata operations.
struct Ops<T: TopicType> {
    sertype: *mut ddsi_sertype,
    _t: PhantomData<T>,
}

/// A serdata with one reference, released on drop.
struct Serdata(*mut ddsi_serdata);

impl Drop for Serdata {
    fn drop(&mut self) {
        // SAFETY: a serdata from the operations below holding the reference we own.
        unsafe { ddsi_serdata_removeref(self.0) }
    }
}

impl<T: TopicType> Ops<T> {
    fn new() -> Self {
        Self {
            sertype: SerType::<T>::into_sertype(SerType::<T>::new()),
            _t: PhantomData,
        }
    }

    fn ops(&self) -> &ddsi_serdata_ops {
        // SAFETY: the sertype is live until drop; cyclonedds-rs set its serdata ops table.
        unsafe { &*(*self.sertype).serdata_ops }
    }

    /// `from_sample`, as `dds_write` calls it with a cyclonedds-rs `Sample`; None for null.
    fn serdata_of_kind(&self, kind: u32, sample: &Sample<T>) -> Option<Serdata> {
        let f = self.ops().from_sample.expect("from_sample");
        // SAFETY: our sertype, and a pointer to a live `Sample<T>` as cyclonedds-rs passes it.
        let sd = unsafe { f(self.sertype, kind, (sample as *const Sample<T>).cast::<c_void>()) };
        (!sd.is_null()).then(|| Serdata(sd))
    }

    fn serdata_of(&self, value: T) -> Serdata {
        self.serdata_of_kind(SDK_DATA, &Sample::from(Arc::new(value)))
            .expect("from_sample gives a serdata for a sample with data")
    }

    fn get_size(&self, sd: &Serdata) -> usize {
        // SAFETY: a live serdata of this sertype.
        unsafe { self.ops().get_size.expect("get_size")(sd.0) as usize }
    }

    /// `to_ser` into a buffer of exactly `size` bytes followed by guard bytes; returns the
    /// buffer and whether the guard survived.
    fn to_ser(&self, sd: &Serdata, offset: usize, size: usize) -> (Vec<u8>, bool) {
        let mut buf = vec![GUARD; size + 64];
        // SAFETY: `buf` has room for `size` bytes (and guard bytes after them).
        unsafe {
            self.ops().to_ser.expect("to_ser")(sd.0, size as _, offset as _, buf.as_mut_ptr().cast());
        }
        let guard_ok = buf[size..].iter().all(|&b| b == GUARD);
        buf.truncate(size);
        (buf, guard_ok)
    }

    /// `to_ser_ref` then `to_ser_unref`, as `nn_xmsg_serdata` / `nn_xmsg_free` do; returns
    /// the reported length and a copy of the referenced bytes (at most `size` of them).
    fn to_ser_ref(&self, sd: &Serdata, offset: usize, size: usize) -> Option<(usize, Vec<u8>)> {
        let mut iov = iovec {
            iov_base: std::ptr::null_mut(),
            iov_len: 0,
        };
        // SAFETY: a live serdata; `iov` is ours.
        let r = unsafe { self.ops().to_ser_ref.expect("to_ser_ref")(sd.0, offset as _, size as _, &mut iov) };
        if r.is_null() {
            return None;
        }
        let len = iov.iov_len as usize;
        // SAFETY: the callback promises `iov_len` readable bytes at `iov_base` until the unref;
        // only the first `min(len, size)` are copied (more would be the overrun under test).
        let bytes = unsafe { std::slice::from_raw_parts(iov.iov_base.cast::<u8>(), len.min(size)) }.to_vec();
        // SAFETY: releases the reference `to_ser_ref` returned.
        unsafe { self.ops().to_ser_unref.expect("to_ser_unref")(r, &iov) };
        Some((len, bytes))
    }

    /// `from_ser_iov` over `chunks` (CycloneDDS hands received bytes over in pieces).
    fn decode_iov(&self, chunks: &[&[u8]]) -> Option<Serdata> {
        let iovs: Vec<iovec> = chunks
            .iter()
            .map(|c| iovec {
                iov_base: c.as_ptr() as *mut c_void,
                iov_len: c.len() as _,
            })
            .collect();
        let size: usize = chunks.iter().map(|c| c.len()).sum();
        // SAFETY: the iovecs describe live byte slices.
        let sd = unsafe {
            self.ops().from_ser_iov.expect("from_ser_iov")(
                self.sertype,
                SDK_DATA,
                iovs.len() as _,
                iovs.as_ptr(),
                size as _,
            )
        };
        (!sd.is_null()).then(|| Serdata(sd))
    }

    /// `to_sample` into a cyclonedds-rs sample, as a take does; (return value, the sample).
    fn to_sample(&self, sd: &Serdata) -> (bool, Option<T>)
    where
        T: Clone,
    {
        let mut sample = Box::new(Sample::<T>::default());
        let p: *mut Sample<T> = &mut *sample;
        // SAFETY: a live serdata and a live `Sample<T>` (what cyclonedds-rs's buffers hold).
        let ok = unsafe {
            self.ops().to_sample.expect("to_sample")(sd.0, p.cast(), std::ptr::null_mut(), std::ptr::null_mut())
        };
        let value = sample.try_deref().cloned();
        (ok, value)
    }
}

impl<T: TopicType> Drop for Ops<T> {
    fn drop(&mut self) {
        // SAFETY: the sertype was never registered with a domain; its own free releases it.
        unsafe { (*(*self.sertype).ops).free.expect("sertype free")(self.sertype) }
    }
}

/// Every `(offset, size)` a fragmenting writer asks for: `frag`-sized pieces of `total` (the
/// serialised size, a multiple of 4; `nn_xmsg_serdata` rounds each part up to one).
fn fragments(total: usize, frag: usize) -> Vec<(usize, usize)> {
    (0..total)
        .step_by(frag)
        .map(|off| (off, (total - off).min(frag)))
        .collect()
}

fn check_serialisation<T: TopicType + Serialize + Clone + PartialEq + std::fmt::Debug>(value: T, what: &str) {
    let want = wire_bytes(&value);
    let ops = Ops::<T>::new();
    let sd = ops.serdata_of(value.clone());

    assert_eq!(
        ops.get_size(&sd),
        want.len(),
        "{what}: get_size must count the padding CycloneDDS sends"
    );

    // The whole sample, and fragments of every size CycloneDDS may ask for (default
    // FragmentSize, a small one, and odd offsets inside the padding's word).
    let mut asks = vec![(0, want.len())];
    for frag in [FRAGMENT, 16, 4] {
        asks.extend(fragments(want.len(), frag));
    }
    asks.push((want.len() - 1, 1));
    for (off, size) in asks {
        let (len, bytes) = ops
            .to_ser_ref(&sd, off, size)
            .unwrap_or_else(|| panic!("{what}: to_ser_ref({off}, {size}) failed"));
        assert_eq!(len, size, "{what}: to_ser_ref({off}, {size}) reports {len} bytes");
        assert_eq!(bytes, want[off..off + size], "{what}: to_ser_ref({off}, {size}) bytes");

        let (bytes, guard_ok) = ops.to_ser(&sd, off, size);
        assert!(
            guard_ok,
            "{what}: to_ser({off}, {size}) wrote past the {size}-byte buffer"
        );
        assert_eq!(bytes, want[off..off + size], "{what}: to_ser({off}, {size}) bytes");
    }

    // What a reader gets back from those bytes, received in two pieces.
    let (a, b) = want.split_at(want.len() / 2);
    let back = ops
        .decode_iov(&[a, b])
        .expect("from_ser_iov decodes CycloneDDS's bytes");
    let (ok, got) = ops.to_sample(&back);
    assert!(ok, "{what}: to_sample must report success for a sample with data");
    assert_eq!(
        got.as_ref(),
        Some(&value),
        "{what}: value after from_ser_iov + to_sample"
    );
    assert_eq!(
        from_cdr::<T>(&want).ok().as_ref(),
        Some(&value),
        "{what}: the expected bytes decode"
    );
}

#[test]
fn inspire_hand_ctrl_65_bytes_is_served_padded_and_in_any_part() {
    let v: inspire::InspireHandCtrl = value_of("inspire", "inspire_hand_ctrl", "typical");
    assert_eq!(to_cdr_be(&v).map(|b| b.len()).ok(), Some(4 + 65), "fixture size");
    check_serialisation(v, "inspire_hand_ctrl");
}

#[test]
fn inspire_hand_state_98_bytes_is_served_padded_and_in_any_part() {
    let v: inspire::InspireHandState = value_of("inspire", "inspire_hand_state", "typical");
    assert_eq!(to_cdr_be(&v).map(|b| b.len()).ok(), Some(4 + 98), "fixture size");
    check_serialisation(v, "inspire_hand_state");
}

#[test]
fn inspire_hand_touch_above_the_fragment_size_is_served_in_fragments() {
    let v: inspire::InspireHandTouch = value_of("inspire", "inspire_hand_touch", "typical");
    assert!(
        to_cdr_be(&v).map(|b| b.len()).unwrap_or(0) > FRAGMENT,
        "fixture above one fragment"
    );
    check_serialisation(v, "inspire_hand_touch");
}

#[test]
fn dex3_hand_state_is_served_in_fragments() {
    let v: unitree_hg::HandState_ = value_of("unitree_hg", "HandState_", "typical");
    check_serialisation(v, "unitree_hg HandState_");
}

#[test]
fn unsupported_requests_return_null_instead_of_panicking_across_ffi() {
    // `dds_register_instance` / `dds_unregister_instance` / `dds_dispose` ask for a key-only
    // serdata; cyclonedds-rs 0.6.5 panics inside the callback (an abort since Rust 1.81).
    // CycloneDDS handles a null serdata (the call fails with an error code).
    let ops = Ops::<inspire::InspireHandCtrl>::new();
    let value: inspire::InspireHandCtrl = value_of("inspire", "inspire_hand_ctrl", "typical");
    let sample = Sample::from(Arc::new(value));
    assert!(
        ops.serdata_of_kind(SDK_KEY, &sample).is_none(),
        "key-only serdata: null"
    );
    // A sample without data (what a cyclonedds-rs sample buffer holds before a take).
    assert!(
        ops.serdata_of_kind(SDK_DATA, &Sample::default()).is_none(),
        "sample without data: null"
    );
    // Bytes that do not decode (truncated): null, not a panic.
    assert!(ops.decode_iov(&[&[0, 0, 0, 0, 1]]).is_none(), "undecodable bytes: null");
}

// Counts of the QoS objects made and deleted in this process: these two definitions interpose
// on libddsc's `dds_create_qos` / `dds_delete_qos` (the test binary exports them, so they take
// the calls of cyclonedds-rs and of libddsc itself) and forward to libddsc's.
static QOS_CREATED: AtomicUsize = AtomicUsize::new(0);
static QOS_DELETED: AtomicUsize = AtomicUsize::new(0);

/// libddsc's definition of `name` (the next one after this binary's).
unsafe fn libddsc_fn(name: &CStr) -> *mut c_void {
    // SAFETY: dlsym with a NUL-terminated name; RTLD_NEXT searches the libraries after us.
    let f = unsafe { libc::dlsym(libc::RTLD_NEXT, name.as_ptr()) };
    assert!(!f.is_null(), "libddsc has no {name:?}");
    f
}

/// # Safety
/// As libddsc's `dds_create_qos`.
#[no_mangle]
pub unsafe extern "C" fn dds_create_qos() -> *mut dds_qos_t {
    QOS_CREATED.fetch_add(1, Ordering::SeqCst);
    // SAFETY: libddsc's dds_create_qos has exactly this signature.
    unsafe {
        let real: unsafe extern "C" fn() -> *mut dds_qos_t = std::mem::transmute(libddsc_fn(c"dds_create_qos"));
        real()
    }
}

/// # Safety
/// As libddsc's `dds_delete_qos`: `qos` is null or a QoS object from `dds_create_qos`.
#[no_mangle]
pub unsafe extern "C" fn dds_delete_qos(qos: *mut dds_qos_t) {
    if !qos.is_null() {
        QOS_DELETED.fetch_add(1, Ordering::SeqCst);
    }
    // SAFETY: libddsc's dds_delete_qos has exactly this signature; `qos` comes from the caller.
    unsafe {
        let real: unsafe extern "C" fn(*mut dds_qos_t) = std::mem::transmute(libddsc_fn(c"dds_delete_qos"));
        real(qos)
    }
}

#[test]
fn endpoints_do_not_leak_their_qos() {
    // cyclonedds-rs 0.6.5 handed the QoS object of every writer / reader / topic / participant
    // it created to CycloneDDS and never deleted it (CycloneDDS copies it): 408 B plus the
    // USER_DATA per endpoint, the 29 blocks "definitely lost" of the default profile's valgrind
    // run. Every QoS the binding makes for an endpoint must be deleted once it is made.
    const N: usize = 50;
    let node = handgate_tests::node(217);
    let opts = EndpointOptions::default().user_data(b"typehash=test;".to_vec());
    let round = || {
        let w = node
            .writer_with::<inspire::InspireHandCtrl>("rt/handgate/test/qos_leak", Qos::BestEffort, &opts)
            .expect("writer");
        let r = node
            .reader_with::<inspire::InspireHandCtrl>("rt/handgate/test/qos_leak", Qos::Reliable { depth: 4 }, &opts)
            .expect("reader");
        drop((w, r));
    };
    // The first round also makes the topic's definition, which keeps a QoS while the topic
    // name is in use.
    round();
    let live = || QOS_CREATED.load(Ordering::SeqCst) as i64 - QOS_DELETED.load(Ordering::SeqCst) as i64;
    let (live_before, created_before) = (live(), QOS_CREATED.load(Ordering::SeqCst));
    for _ in 0..N {
        round();
    }
    let created = QOS_CREATED.load(Ordering::SeqCst) - created_before;
    assert!(
        created >= 2 * N,
        "the endpoints were made with a QoS ({created} created)"
    );
    // CycloneDDS frees a deleted endpoint's QoS on its garbage-collector thread: wait for the
    // count of live QoS objects to come back to where it was (never, with the leak).
    let settled = handgate_tests::poll(Duration::from_secs(30), || (live() == live_before).then_some(()));
    println!(
        "{N} writer + reader pairs: {created} QoS objects made, {} still live",
        live() - live_before
    );
    assert!(
        settled.is_some(),
        "{} QoS objects of deleted endpoints were never deleted",
        live() - live_before
    );
}

/// Domain of the SDK round trip (`tests/python/echo_peer.py`).
const ECHO_DOMAIN: u32 = 218;
/// Upper bound of one wait: Python start-up, discovery, and the binding under valgrind
/// (`scripts/valgrind.sh wire` runs this test there, tens of times slower).
const ECHO_DEADLINE: Duration = Duration::from_secs(300);

fn echo_topic(key: &str, direction: &str) -> String {
    format!("rt/handgate/test/echo/{}/{direction}", key.replace('/', "_"))
}

/// `value` written by handgate's binding, read and written back by the SDK, read by the
/// binding: equal at both ends (compared as little-endian CDR, which also holds for NaN).
fn round_trip<T>(node: &Node, peer: &PyProcess, key: &str, value: &T)
where
    T: TopicType + FromPlain + Serialize + Clone + PartialEq + std::fmt::Debug,
{
    let same = |got: &T, what: &str| {
        if to_cdr_le(got).ok() != to_cdr_le(value).ok() {
            assert_eq!(got, value, "{key}: {what}");
            panic!("{key}: {what}: values equal but bits differ");
        }
    };
    let mut w = node
        .writer::<T>(&echo_topic(key, "to_py"), Qos::Reliable { depth: 1 })
        .expect("writer");
    let r = node
        .reader::<T>(&echo_topic(key, "to_rs"), Qos::BestEffort)
        .expect("reader");
    w.wait_matched(1, ECHO_DEADLINE)
        .and_then(|_| r.wait_matched(1, ECHO_DEADLINE))
        .unwrap_or_else(|e| panic!("{key}: {e}\n{}", peer.transcript()));
    let mut back = Vec::new();
    let echoed = stream_until(&mut w, value, ECHO_DEADLINE, || {
        back.extend(r.take());
        !back.is_empty()
    });
    assert!(echoed, "{key}: nothing came back\n{}", peer.transcript());
    let line = peer
        .wait_line(&format!("GOT {key} "), ECHO_DEADLINE)
        .unwrap_or_else(|e| panic!("{key}: {e}"));
    let seen: T = from_plain_json(&line).unwrap_or_else(|e| panic!("{key}: {e}\nline: {line}"));
    same(&seen, "what unitree_sdk2py read");
    for got in &back {
        same(got, "what came back");
    }
    println!(
        "{key}: {} B on the wire, read back {} time(s)",
        wire_bytes(value).len(),
        back.len()
    );
}

#[test]
fn every_wire_type_round_trips_through_the_sdk() {
    let mut args = vec!["--domain".to_string(), ECHO_DOMAIN.to_string()];
    if let Some(iface) = interop_interface() {
        args.extend(["--interface".to_string(), iface]);
    }
    let peer = PyProcess::spawn("echo_peer.py", &args).expect("python peer");
    peer.wait_line("READY", ECHO_DEADLINE).unwrap_or_else(|e| panic!("{e}"));
    let node = handgate_tests::node(ECHO_DOMAIN);

    round_trip::<unitree_hg::HandCmd_>(
        &node,
        &peer,
        "unitree_hg/HandCmd_",
        &value_of("unitree_hg", "HandCmd_", "typical"),
    );
    // 1428 B: above the default fragment size.
    round_trip::<unitree_hg::HandState_>(
        &node,
        &peer,
        "unitree_hg/HandState_",
        &value_of("unitree_hg", "HandState_", "typical"),
    );
    round_trip::<unitree_go::MotorCmds_>(
        &node,
        &peer,
        "unitree_go/MotorCmds_",
        &value_of("unitree_go", "MotorCmds_", "typical"),
    );
    round_trip::<unitree_go::MotorStates_>(
        &node,
        &peer,
        "unitree_go/MotorStates_",
        &value_of("unitree_go", "MotorStates_", "typical"),
    );
    // 65 B and 98 B: not a multiple of 4 (padded on the wire).
    round_trip::<inspire::InspireHandCtrl>(
        &node,
        &peer,
        "inspire/inspire_hand_ctrl",
        &value_of("inspire", "inspire_hand_ctrl", "typical"),
    );
    round_trip::<inspire::InspireHandState>(
        &node,
        &peer,
        "inspire/inspire_hand_state",
        &value_of("inspire", "inspire_hand_state", "typical"),
    );
    // 2.2 KB: two fragments.
    round_trip::<inspire::InspireHandTouch>(
        &node,
        &peer,
        "inspire/inspire_hand_touch",
        &value_of("inspire", "inspire_hand_touch", "typical"),
    );
    round_trip::<handgate::HandCmd_>(
        &node,
        &peer,
        "handgate/HandCmd_",
        &value_of("handgate", "HandCmd_", "typical"),
    );
    round_trip::<handgate::HandState_>(
        &node,
        &peer,
        "handgate/HandState_",
        &value_of("handgate", "HandState_", "typical"),
    );
    round_trip::<ros2::JointState_>(
        &node,
        &peer,
        "sensor_msgs/JointState_",
        &value_of("sensor_msgs", "JointState_", "typical"),
    );
    // Above 10 fragments (13,440 B): CycloneDDS 0.10.2 sends a new sample in DATA_FRAG
    // submessages of at most MaxMessageSize / FragmentSize fragments, so this one is asked of
    // to_ser_ref in two parts, the second at an offset, and reassembled from several fragments
    // on both sides.
    let mut status: handgate::GatewayStatus_ = value_of("handgate", "GatewayStatus_", "typical");
    let one = status.devices.first().cloned().expect("typical status has a device");
    while wire_bytes(&status).len() <= 10 * FRAGMENT + FRAGMENT {
        status.devices.push(one.clone());
    }
    round_trip::<handgate::GatewayStatus_>(&node, &peer, "handgate/GatewayStatus_", &status);
}
