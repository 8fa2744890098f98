//! Dex3-1 over USB: the bulk protocol of the Dex3-1 user manual (one 1234-byte command frame
//! out, one 1270-byte state frame back), a transport seam with a libusb implementation, an
//! emulator of the hand's MCU (in process or behind a Unix socket), wiring discovery and the
//! 1 kHz device loop. See docs/dex3-usb.md.

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
