//! Dex3-1 over USB: the bulk protocol of the Dex3-1 user manual (one 1234-byte command frame
//! out, one 1270-byte state frame back), a transport seam with a libusb implementation, an
//! emulator of the hand's MCU (in process or behind a Unix socket), wiring discovery and the
//! 1 kHz device loop. See docs/dex3-usb.md.

pub mod adapter;
pub mod align;
pub mod codec;
pub mod convert;
pub mod crc;
pub mod device_loop;
pub mod discovery;
pub mod emulator;
pub mod rusb_transport;
pub mod scaling;
pub mod socket;
pub mod transport;
pub mod wiring;

pub use align::Align;
pub use codec::{BusId, DeviceId, CMD_FRAME_LEN, STATE_FRAME_LEN};
pub use device_loop::{Dex3UsbHandle, Dex3UsbLoop, Link, LoopConfig, LoopError, LoopStats, Observer, PeriodHistogram};
pub use discovery::{discover, DiscoveryOptions, DiscoveryReport};
pub use emulator::{Dex3Emulator, EmulatorClock, EmulatorConfig, EmulatorTransport, SharedEmulator};
pub use rusb_transport::{list_hands, HandInfo, RusbTransport};
pub use scaling::Scalings;
pub use socket::{run_emulator_server, EmulatorServer, UnixSocketTransport};
pub use transport::{Dex3Transport, TransportError, TransportFactory};
pub use wiring::{BusAddr, WiringMap};
