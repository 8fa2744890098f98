//! The real link: libusb through `rusb`.
//!
//! Opens the hand by VID 0x34B7 / PID 0x1010 (left) or 0x1011 (right) (manual "USB Device ID"),
//! optionally by serial number when several hands are plugged in; reads the bulk IN/OUT
//! endpoints of interface 0 from the descriptors (an unofficial source says 0x02 out / 0x81 in:
//! docs/sources.md §3 says read them instead); detaches a kernel driver and claims interface 0.
//!
//! Reconnect after an unplug is the device loop's job: the transport reports
//! [`TransportError::Disconnected`] and the loop calls the factory again with backoff.
//!
//! NOT TESTED ON HARDWARE (there is none here). Unit tests cover what is pure: endpoint
//! selection over a descriptor model and the error mapping.

use super::codec::{CMD_FRAME_LEN, STATE_FRAME_LEN};
use super::transport::{Dex3Transport, TransportError, TransportFactory};
use crate::dex3::Side;
use rusb::UsbContext;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Unitree's USB vendor id (manual).
pub const VENDOR_ID: u16 = 0x34B7;
/// Left hand product id (manual).
pub const PRODUCT_ID_LEFT: u16 = 0x1010;
/// Right hand product id (manual).
pub const PRODUCT_ID_RIGHT: u16 = 0x1011;
/// The interface the manual claims.
pub const INTERFACE: u8 = 0;
/// Receive buffer (the manual's `BUF_SIZE`): larger than a state frame, so a longer reply is
/// reported instead of overflowing.
const RX_BUF: usize = 4096;

pub fn product_id(side: Side) -> u16 {
    match side {
        // A Dex3 is a left or a right hand; profiles reject `center` for it.
        Side::Left | Side::Center => PRODUCT_ID_LEFT,
        Side::Right => PRODUCT_ID_RIGHT,
    }
}

pub fn side_of(vid: u16, pid: u16) -> Option<Side> {
    match (vid, pid) {
        (VENDOR_ID, PRODUCT_ID_LEFT) => Some(Side::Left),
        (VENDOR_ID, PRODUCT_ID_RIGHT) => Some(Side::Right),
        _ => None,
    }
}

/// Descriptor model (what endpoint selection needs), filled from rusb or built by tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EpDir {
    In,
    Out,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EpKind {
    Control,
    Isochronous,
    Bulk,
    Interrupt,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EndpointModel {
    pub address: u8,
    pub dir: EpDir,
    pub kind: EpKind,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InterfaceModel {
    pub number: u8,
    pub alt_setting: u8,
    pub endpoints: Vec<EndpointModel>,
}

/// Picks the first bulk IN and first bulk OUT endpoint of `interface` (alternate setting 0
/// first, then others). Returns `(in_address, out_address)`.
pub fn select_bulk_endpoints(ifaces: &[InterfaceModel], interface: u8) -> Result<(u8, u8), TransportError> {
    let mut candidates: Vec<&InterfaceModel> = ifaces.iter().filter(|i| i.number == interface).collect();
    candidates.sort_by_key(|i| i.alt_setting);
    for i in candidates {
        let find = |dir| {
            i.endpoints
                .iter()
                .find(|e| e.kind == EpKind::Bulk && e.dir == dir)
                .map(|e| e.address)
        };
        if let (Some(ep_in), Some(ep_out)) = (find(EpDir::In), find(EpDir::Out)) {
            return Ok((ep_in, ep_out));
        }
    }
    Err(TransportError::NoEndpoints(interface))
}

/// The usbfs device node libusb opens for the device at `bus`/`address` on Linux.
pub fn usb_node(bus: u8, address: u8) -> PathBuf {
    PathBuf::from(format!("/dev/bus/usb/{bus:03}/{address:03}"))
}

/// Maps a libusb error to the transport's, naming `what` (the device) where useful.
pub fn map_usb_error(e: rusb::Error, what: &str, timeout: Duration) -> TransportError {
    map_usb_error_at(e, what, None, timeout)
}

/// [`map_usb_error`] for one device whose node (`/dev/bus/usb/BBB/DDD`) is known: a
/// permission error then names the node and the fix.
pub fn map_usb_error_at(e: rusb::Error, what: &str, node: Option<&Path>, timeout: Duration) -> TransportError {
    match e {
        rusb::Error::Timeout => TransportError::Timeout(timeout),
        rusb::Error::NoDevice => TransportError::Disconnected,
        rusb::Error::NotFound => TransportError::NotFound(what.to_string()),
        rusb::Error::Access => TransportError::UsbPermissionDenied {
            device: what.to_string(),
            node: node.map(Path::to_path_buf),
            source: e,
        },
        rusb::Error::Busy => TransportError::Busy(what.to_string()),
        rusb::Error::Io => TransportError::Usb(format!("{what}: input/output error (cable or hub trouble?)")),
        rusb::Error::Pipe => TransportError::Usb(format!("{what}: endpoint stalled")),
        rusb::Error::Overflow => TransportError::Usb(format!("{what}: device sent more than expected")),
        other => TransportError::Usb(format!("{what}: {other}")),
    }
}

fn interfaces_of(config: &rusb::ConfigDescriptor) -> Vec<InterfaceModel> {
    let mut out = Vec::new();
    for iface in config.interfaces() {
        for d in iface.descriptors() {
            out.push(InterfaceModel {
                number: d.interface_number(),
                alt_setting: d.setting_number(),
                endpoints: d
                    .endpoint_descriptors()
                    .map(|e| EndpointModel {
                        address: e.address(),
                        dir: match e.direction() {
                            rusb::Direction::In => EpDir::In,
                            rusb::Direction::Out => EpDir::Out,
                        },
                        kind: match e.transfer_type() {
                            rusb::TransferType::Control => EpKind::Control,
                            rusb::TransferType::Isochronous => EpKind::Isochronous,
                            rusb::TransferType::Bulk => EpKind::Bulk,
                            rusb::TransferType::Interrupt => EpKind::Interrupt,
                        },
                    })
                    .collect(),
            });
        }
    }
    out
}

/// A hand seen on the USB buses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HandInfo {
    pub side: Side,
    /// `None` when it could not be read (see `problem`).
    pub serial: Option<String>,
    pub bus: u8,
    pub address: u8,
    /// Why the device could not be opened, if it could not (e.g. permissions).
    pub problem: Option<String>,
}

fn device_name(side: Side, bus: u8, address: u8) -> String {
    format!("Dex3-1 {} hand at USB bus {bus:03} device {address:03}", side.as_str())
}

/// Lists every Dex3-1 hand on the USB buses. A hand that cannot be opened is still listed with
/// the reason (e.g. the udev rule is missing) in `problem`.
pub fn list_hands() -> Result<Vec<HandInfo>, TransportError> {
    let ctx = rusb::Context::new().map_err(|e| map_usb_error(e, "libusb", Duration::ZERO))?;
    let devices = ctx
        .devices()
        .map_err(|e| map_usb_error(e, "USB device list", Duration::ZERO))?;
    let mut out = Vec::new();
    for dev in devices.iter() {
        let Ok(desc) = dev.device_descriptor() else { continue };
        let Some(side) = side_of(desc.vendor_id(), desc.product_id()) else {
            continue;
        };
        let (bus, address) = (dev.bus_number(), dev.address());
        let name = device_name(side, bus, address);
        let node = usb_node(bus, address);
        let problem = |e| Some(map_usb_error_at(e, &name, Some(&node), Duration::ZERO).to_string());
        let (serial, problem) = match dev.open() {
            Ok(h) => match h.read_serial_number_string_ascii(&desc) {
                Ok(s) => (Some(s), None),
                Err(e) => (None, problem(e)),
            },
            Err(e) => (None, problem(e)),
        };
        out.push(HandInfo {
            side,
            serial,
            bus,
            address,
            problem,
        });
    }
    Ok(out)
}

/// An open, claimed Dex3-1 USB link.
pub struct RusbTransport {
    handle: rusb::DeviceHandle<rusb::Context>,
    ep_in: u8,
    ep_out: u8,
    name: String,
    flush_before_next: bool,
    rx: Box<[u8; RX_BUF]>,
}

impl RusbTransport {
    /// Opens the `side` hand, the one with `serial` if given.
    pub fn open(side: Side, serial: Option<&str>) -> Result<Self, TransportError> {
        let ctx = rusb::Context::new().map_err(|e| map_usb_error(e, "libusb", Duration::ZERO))?;
        let devices = ctx
            .devices()
            .map_err(|e| map_usb_error(e, "USB device list", Duration::ZERO))?;
        let mut last_err = None;
        let mut seen = Vec::new();
        for dev in devices.iter() {
            let Ok(desc) = dev.device_descriptor() else { continue };
            if side_of(desc.vendor_id(), desc.product_id()) != Some(side) {
                continue;
            }
            let name = device_name(side, dev.bus_number(), dev.address());
            let node = usb_node(dev.bus_number(), dev.address());
            let handle = match dev.open() {
                Ok(h) => h,
                Err(e) => {
                    last_err = Some(map_usb_error_at(e, &name, Some(&node), Duration::ZERO));
                    continue;
                }
            };
            if let Some(want) = serial {
                match handle.read_serial_number_string_ascii(&desc) {
                    Ok(s) if s == want => {}
                    Ok(s) => {
                        seen.push(s);
                        continue;
                    }
                    Err(e) => {
                        last_err = Some(map_usb_error_at(e, &name, Some(&node), Duration::ZERO));
                        continue;
                    }
                }
            }
            return Self::claim(dev, handle, name, node);
        }
        if let Some(e) = last_err {
            return Err(e);
        }
        let pid = product_id(side);
        Err(TransportError::NotFound(match serial {
            Some(s) if !seen.is_empty() => format!(
                "no Dex3-1 {} hand with serial {s} (found serials: {})",
                side.as_str(),
                seen.join(", ")
            ),
            Some(s) => format!(
                "no Dex3-1 {} hand with serial {s} ({VENDOR_ID:04x}:{pid:04x})",
                side.as_str()
            ),
            None => format!(
                "no Dex3-1 {} hand ({VENDOR_ID:04x}:{pid:04x}); check the cable, the hand's power and `lsusb`",
                side.as_str()
            ),
        }))
    }

    fn claim(
        dev: rusb::Device<rusb::Context>,
        handle: rusb::DeviceHandle<rusb::Context>,
        name: String,
        node: PathBuf,
    ) -> Result<Self, TransportError> {
        let err = |e| map_usb_error_at(e, &name, Some(&node), Duration::ZERO);
        let config = dev
            .active_config_descriptor()
            .or_else(|_| dev.config_descriptor(0))
            .map_err(err)?;
        let (ep_in, ep_out) = select_bulk_endpoints(&interfaces_of(&config), INTERFACE)?;
        if let Ok(true) = handle.kernel_driver_active(INTERFACE) {
            handle.detach_kernel_driver(INTERFACE).map_err(err)?;
        }
        handle.claim_interface(INTERFACE).map_err(err)?;
        tracing::info!("{name}: claimed interface {INTERFACE}, bulk in {ep_in:#04x} out {ep_out:#04x}");
        Ok(Self {
            handle,
            ep_in,
            ep_out,
            name,
            flush_before_next: false,
            rx: Box::new([0; RX_BUF]),
        })
    }

    /// A factory for the device loop (reopens after unplug).
    pub fn factory(side: Side, serial: Option<String>) -> TransportFactory {
        Box::new(move || Ok(Box::new(RusbTransport::open(side, serial.as_deref())?) as Box<dyn Dex3Transport>))
    }

    /// Endpoint addresses found in the descriptors `(in, out)`.
    pub fn endpoints(&self) -> (u8, u8) {
        (self.ep_in, self.ep_out)
    }

    /// After a timed-out exchange a late reply may sit in the IN endpoint: read it away so
    /// the next exchange does not take it for its own.
    fn flush_in(&mut self) {
        for _ in 0..4 {
            if self
                .handle
                .read_bulk(self.ep_in, &mut self.rx[..], Duration::from_millis(1))
                .is_err()
            {
                break;
            }
        }
    }
}

impl Dex3Transport for RusbTransport {
    fn exchange(
        &mut self,
        cmd: &[u8; CMD_FRAME_LEN],
        state: &mut [u8; STATE_FRAME_LEN],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        // rusb: a zero timeout means "wait forever".
        let timeout = timeout.max(Duration::from_millis(1));
        if self.flush_before_next {
            self.flush_in();
            self.flush_before_next = false;
        }
        let sent = self
            .handle
            .write_bulk(self.ep_out, cmd, timeout)
            .map_err(|e| map_usb_error(e, &self.name, timeout))?;
        if sent != CMD_FRAME_LEN {
            return Err(TransportError::Usb(format!(
                "{}: wrote {sent} of {CMD_FRAME_LEN} bytes",
                self.name
            )));
        }
        match self.handle.read_bulk(self.ep_in, &mut self.rx[..], timeout) {
            Ok(n) if n >= STATE_FRAME_LEN => {
                if n > STATE_FRAME_LEN {
                    tracing::debug!("{}: reply of {n} bytes, using the first {STATE_FRAME_LEN}", self.name);
                }
                state.copy_from_slice(&self.rx[..STATE_FRAME_LEN]);
                Ok(())
            }
            Ok(n) => Err(TransportError::ShortReply {
                got: n,
                expected: STATE_FRAME_LEN,
            }),
            Err(e) => {
                if e == rusb::Error::Timeout {
                    self.flush_before_next = true;
                }
                Err(map_usb_error(e, &self.name, timeout))
            }
        }
    }

    fn describe(&self) -> String {
        self.name.clone()
    }
}

impl Drop for RusbTransport {
    fn drop(&mut self) {
        let _ = self.handle.release_interface(INTERFACE);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ep(address: u8, dir: EpDir, kind: EpKind) -> EndpointModel {
        EndpointModel { address, dir, kind }
    }

    #[test]
    fn picks_bulk_pair_of_interface_0() {
        let ifaces = vec![
            InterfaceModel {
                number: 1,
                alt_setting: 0,
                endpoints: vec![ep(0x83, EpDir::In, EpKind::Bulk), ep(0x04, EpDir::Out, EpKind::Bulk)],
            },
            InterfaceModel {
                number: 0,
                alt_setting: 0,
                endpoints: vec![
                    ep(0x85, EpDir::In, EpKind::Interrupt),
                    ep(0x81, EpDir::In, EpKind::Bulk),
                    ep(0x02, EpDir::Out, EpKind::Bulk),
                ],
            },
        ];
        assert_eq!(select_bulk_endpoints(&ifaces, 0).unwrap(), (0x81, 0x02));
        assert_eq!(select_bulk_endpoints(&ifaces, 1).unwrap(), (0x83, 0x04));
    }

    #[test]
    fn falls_back_to_alt_setting_and_reports_missing() {
        let ifaces = vec![
            InterfaceModel {
                number: 0,
                alt_setting: 1,
                endpoints: vec![ep(0x86, EpDir::In, EpKind::Bulk), ep(0x07, EpDir::Out, EpKind::Bulk)],
            },
            InterfaceModel {
                number: 0,
                alt_setting: 0,
                endpoints: vec![
                    ep(0x81, EpDir::In, EpKind::Bulk),
                    ep(0x01, EpDir::Out, EpKind::Interrupt),
                ],
            },
        ];
        assert_eq!(select_bulk_endpoints(&ifaces, 0).unwrap(), (0x86, 0x07));
        assert!(matches!(
            select_bulk_endpoints(&ifaces[1..], 0),
            Err(TransportError::NoEndpoints(0))
        ));
        assert!(matches!(
            select_bulk_endpoints(&[], 0),
            Err(TransportError::NoEndpoints(0))
        ));
    }

    #[test]
    fn error_mapping() {
        let t = Duration::from_millis(5);
        assert!(matches!(map_usb_error(rusb::Error::Timeout, "h", t), TransportError::Timeout(d) if d == t));
        assert!(matches!(
            map_usb_error(rusb::Error::NoDevice, "h", t),
            TransportError::Disconnected
        ));
        let perm = map_usb_error(rusb::Error::Access, "hand", t);
        assert!(
            matches!(&perm, TransportError::UsbPermissionDenied { node: None, .. }),
            "{perm}"
        );
        assert!(perm.to_string().contains("99-handgate-dex3.rules"), "{perm}");
        assert!(perm.needs_reconnect());
        assert!(matches!(
            map_usb_error(rusb::Error::Busy, "h", t),
            TransportError::Busy(_)
        ));
        assert!(map_usb_error(rusb::Error::Busy, "h", t).needs_reconnect());
        assert!(!map_usb_error(rusb::Error::Timeout, "h", t).needs_reconnect());
        assert!(matches!(
            map_usb_error(rusb::Error::NotFound, "h", t),
            TransportError::NotFound(_)
        ));
        assert!(matches!(
            map_usb_error(rusb::Error::Pipe, "h", t),
            TransportError::Usb(_)
        ));
    }

    /// No USB hardware here: what a hand whose node handgate's user cannot open produces is
    /// checked at the mapping (libusb reports EACCES on the node as `rusb::Error::Access`).
    #[test]
    fn permission_error_names_the_node_and_the_fix() {
        use std::error::Error as _;
        let node = usb_node(1, 5);
        assert_eq!(node, Path::new("/dev/bus/usb/001/005"));
        let e = map_usb_error_at(
            rusb::Error::Access,
            &device_name(Side::Left, 1, 5),
            Some(&node),
            Duration::ZERO,
        );
        let msg = e.to_string();
        for want in [
            "permission denied opening Dex3-1 left hand at USB bus 001 device 005 (/dev/bus/usb/001/005)",
            "/etc/udev/rules.d/",
            "99-handgate-dex3.rules",
            "udevadm trigger",
            "group plugdev",
            "usermod -aG plugdev",
            "SupplementaryGroups=plugdev",
        ] {
            assert!(msg.contains(want), "missing {want:?} in: {msg}");
        }
        let source = e.source().expect("the libusb error is the source");
        assert_eq!(source.downcast_ref::<rusb::Error>(), Some(&rusb::Error::Access));
        assert!(
            e.needs_reconnect(),
            "the loop keeps retrying: a udev fix needs no restart"
        );
    }

    #[test]
    fn ids() {
        assert_eq!(side_of(0x34B7, 0x1010), Some(Side::Left));
        assert_eq!(side_of(0x34B7, 0x1011), Some(Side::Right));
        assert_eq!(side_of(0x34B8, 0x1011), None);
        assert_eq!(product_id(Side::Right), 0x1011);
    }
}
