//! The transport seam: one exchange = send one 1234-byte command frame, receive one 1270-byte
//! state frame. The libusb transport, the in-process emulator and the Unix-socket client all sit
//! behind [`Dex3Transport`], exactly where the hardware would be.

use super::codec::{CMD_FRAME_LEN, STATE_FRAME_LEN};
use std::time::Duration;
use thiserror::Error;

/// The udev rule file shipped with handgate (mentioned in permission errors).
pub const UDEV_RULE_PATH: &str = "profiles/udev/99-handgate-dex3.rules";

/// Errors of one exchange or of opening a transport.
#[derive(Debug, Error)]
pub enum TransportError {
    #[error("no reply within {0:?}")]
    Timeout(Duration),
    #[error("device disconnected")]
    Disconnected,
    #[error("not found: {0}")]
    NotFound(String),
    #[error(
        "permission denied opening {0}: install the udev rule ({UDEV_RULE_PATH} into /etc/udev/rules.d/, then \
         `sudo udevadm control --reload && sudo udevadm trigger` and replug) or run as a member of the group it names"
    )]
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
