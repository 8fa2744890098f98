//! The transport seam: one exchange = send one 1234-byte command frame, receive one 1270-byte
//! state frame. The libusb transport, the in-process emulator and the Unix-socket client all sit
//! behind [`Dex3Transport`], exactly where the hardware would be.

use super::codec::{CMD_FRAME_LEN, STATE_FRAME_LEN};
use std::path::{Path, PathBuf};
use std::time::Duration;
use thiserror::Error;

/// The udev rule file shipped with handgate (mentioned in permission errors).
pub const UDEV_RULE_PATH: &str = "profiles/udev/99-handgate-dex3.rules";
/// The group that rule gives the hands' USB device nodes to (`GROUP=` in the rule).
pub const UDEV_GROUP: &str = "plugdev";

/// ` (/dev/bus/usb/BBB/DDD)` when the device node is known.
fn node_suffix(node: &Option<PathBuf>) -> String {
    node.as_deref()
        .map(|n: &Path| format!(" ({})", n.display()))
        .unwrap_or_default()
}

/// Errors of one exchange or of opening a transport.
#[derive(Debug, Error)]
pub enum TransportError {
    #[error("no reply within {0:?}")]
    Timeout(Duration),
    #[error("device disconnected")]
    Disconnected,
    #[error("not found: {0}")]
    NotFound(String),
    /// libusb could not open the hand's device node (EACCES): the node is not readable and
    /// writable by handgate's user. Never needs root: the udev rule and its group fix it.
    #[error(
        "permission denied opening {device}{}: handgate's user cannot read and write that USB device node. \
         Fix: install the udev rule ({UDEV_RULE_PATH} into /etc/udev/rules.d/, then \
         `sudo udevadm control --reload && sudo udevadm trigger` and replug the hand), which gives the node \
         to group {UDEV_GROUP}, and run handgate as a member of {UDEV_GROUP} \
         (`sudo usermod -aG {UDEV_GROUP} <user>` and log in again; the systemd unit has \
         SupplementaryGroups={UDEV_GROUP}); root is not needed",
        node_suffix(.node)
    )]
    UsbPermissionDenied {
        /// The hand, e.g. "Dex3-1 left hand at USB bus 001 device 005".
        device: String,
        /// Its usbfs node, `/dev/bus/usb/BBB/DDD`, when known.
        node: Option<PathBuf>,
        #[source]
        source: rusb::Error,
    },
    /// Any other permission refusal (the emulator's Unix socket).
    #[error("permission denied opening {0}")]
    PermissionDenied(String),
    #[error("{0} is busy: another process holds interface 0 (is another handgate or the vendor service running?)")]
    Busy(String),
    #[error("short reply: {got} of {expected} bytes")]
    ShortReply { got: usize, expected: usize },
    #[error("no bulk IN/OUT endpoint pair on interface {0}")]
    NoEndpoints(u8),
    #[error("USB error: {0}")]
    Usb(String),
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}

impl TransportError {
    /// The transport is unusable and must be reopened (as opposed to one failed exchange).
    pub fn needs_reconnect(&self) -> bool {
        matches!(
            self,
            TransportError::Disconnected
                | TransportError::NotFound(_)
                | TransportError::UsbPermissionDenied { .. }
                | TransportError::PermissionDenied(_)
                | TransportError::Busy(_)
                | TransportError::NoEndpoints(_)
                | TransportError::Io(_)
        )
    }
}

/// One hand link.
pub trait Dex3Transport: Send {
    /// Sends `cmd` and fills `state` with the reply, waiting at most `timeout` for it.
    fn exchange(
        &mut self,
        cmd: &[u8; CMD_FRAME_LEN],
        state: &mut [u8; STATE_FRAME_LEN],
        timeout: Duration,
    ) -> Result<(), TransportError>;

    /// Human-readable description (device path, serial, socket).
    fn describe(&self) -> String {
        "dex3 transport".into()
    }
}

impl<T: Dex3Transport + ?Sized> Dex3Transport for Box<T> {
    fn exchange(
        &mut self,
        cmd: &[u8; CMD_FRAME_LEN],
        state: &mut [u8; STATE_FRAME_LEN],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        (**self).exchange(cmd, state, timeout)
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
}

/// Opens a transport; called again by the device loop after a disconnect.
pub type TransportFactory = Box<dyn FnMut() -> Result<Box<dyn Dex3Transport>, TransportError> + Send>;
