//! The serial kit every bus kind uses (EZGripper, Robotiq, LEAP Hand, Inspire RH56): the
//! byte-pipe seam ([`Transport`], [`Connector`]), the raw-termios port that owns its device
//! exclusively ([`SerialPort`]: `TIOCEXCL` and an advisory `flock`, a second opener told who
//! holds it, [`owner`]), and the pseudo-terminal emulators and fronts stand behind ([`pty`]).
//! docs/adapters.md, "The serial kit".

pub mod owner;
pub mod pty;
pub mod transport;

pub use owner::{holders, PortHolder};
pub use pty::{replace_symlink, Pty};
pub use transport::{Connector, SerialConnector, SerialPort, Transport, TransportError, SERIAL_GROUP};
