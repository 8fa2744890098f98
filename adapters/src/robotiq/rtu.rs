//! The gripper over Modbus RTU: on a serial line (an RS-485 adapter) or RTU frames over TCP
//! (a UR arm's Tool Communication forwarder), through the Modbus kit's master. One exchange is
//! one FC23 (write the request at 0x03E8, read the status at 0x07D0), as Robotiq's own C++
//! SDK does. A link that fails is reopened (an unplugged adapter, a dropped connection) at
//! most every [`REOPEN_EVERY`], never replaying a stale request: the device's driver decides
//! what the next exchange writes.

use std::net::ToSocketAddrs;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use super::device::{Link, LinkError};
use super::open::{Line, RobotiqOpen};
use super::regs::{Request, Status, REQUEST_ADDR, STATUS_ADDR, WORDS};
use crate::device::DeviceError;
use crate::modbus::master::{MasterError, RtuMaster, RtuTiming, TcpTransport};
use crate::serial::transport::{Connector, SerialConnector, Transport, TransportError};

/// Least time between two attempts to reopen a failed link.
pub const REOPEN_EVERY: Duration = Duration::from_millis(500);

/// RTU over TCP to `host:port`, reconnected on demand.
#[derive(Debug, Clone)]
pub struct TcpConnector {
    pub host: String,
    pub port: u16,
    pub timeout: Duration,
}

impl Connector for TcpConnector {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError> {
        let mut last = None;
        for addr in (self.host.as_str(), self.port).to_socket_addrs()? {
            match TcpTransport::connect(addr, self.timeout) {
                Ok(t) => return Ok(Box::new(t)),
                Err(e) => last = Some(e),
            }
        }
        Err(TransportError::Io(last.unwrap_or_else(|| {
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("{} resolves to no address", self.host),
            )
        })))
    }

    fn describe(&self) -> String {
        format!("RTU over TCP {}:{}", self.host, self.port)
    }
}

/// A gripper on an RTU line.
pub struct RtuLink {
    master: RtuMaster,
    connector: Box<dyn Connector>,
    slave: u8,
    /// The transport failed: reopen before the next exchange.
    down: bool,
    last_attempt: Option<Instant>,
}

impl RtuLink {
    /// Opens the line (`connector`) with `timing`, for slave `slave`.
    pub fn open(mut connector: Box<dyn Connector>, timing: RtuTiming, slave: u8) -> Result<Self, TransportError> {
        let transport = connector.connect()?;
        Ok(Self {
            master: RtuMaster::new(transport, timing),
            connector,
            slave,
            down: false,
            last_attempt: None,
        })
    }

    /// What the master counted for the gripper.
    pub fn counters(&self) -> crate::modbus::master::SlaveCounters {
        self.master.counters(self.slave)
    }
}

impl Link for RtuLink {
    fn exchange(&mut self, request: &Request) -> Result<Status, LinkError> {
        if self.down {
            return Err(LinkError::Io(std::io::Error::new(
                std::io::ErrorKind::NotConnected,
                "the line is being reopened",
            )));
        }
        let mut w = [0u16; WORDS];
        match self
            .master
            .read_write(self.slave, STATUS_ADDR, &mut w, REQUEST_ADDR, &request.to_words())
        {
            Ok(()) => Ok(Status::from_words(&w)),
            Err(e) => {
                if e.is_link_error() {
                    self.down = true;
                }
                Err(match e {
                    MasterError::Timeout { timeout, .. } => LinkError::Timeout(timeout),
                    MasterError::BadCrc { .. } => LinkError::Crc,
                    MasterError::Transport(TransportError::Io(io)) | MasterError::Io(io) => LinkError::Io(io),
                    other => LinkError::Unexpected(other.to_string()),
                })
            }
        }
    }

    fn recover(&mut self) -> Result<(), LinkError> {
        if !self.down || self.last_attempt.is_some_and(|t| t.elapsed() < REOPEN_EVERY) {
            return Ok(());
        }
        self.last_attempt = Some(Instant::now());
        let t = self
            .connector
            .connect()
            .map_err(|e| LinkError::Unexpected(e.to_string()))?;
        self.master.replace_transport(t);
        self.down = false;
        tracing::info!(link = %self.connector.describe(), "robotiq: line reopened");
        Ok(())
    }

    fn describe(&self) -> String {
        format!("{} slave {}", self.connector.describe(), self.slave)
    }
}

/// The link `c` describes (serial or TCP).
pub fn open_link(c: &RobotiqOpen) -> Result<Box<dyn Link>, DeviceError> {
    let (connector, timing): (Box<dyn Connector>, RtuTiming) = match &c.line {
        Line::Serial { port, baud } => (
            Box::new(SerialConnector {
                path: PathBuf::from(port),
                baud: *baud,
            }),
            RtuTiming {
                response_timeout: c.response_timeout.unwrap_or(super::open::DEFAULT_RESPONSE_TIMEOUT),
                ..RtuTiming::serial(*baud)
            },
        ),
        Line::Tcp { host, port } => (
            Box::new(TcpConnector {
                host: host.clone(),
                port: *port,
                timeout: Duration::from_secs(2),
            }),
            RtuTiming {
                response_timeout: c.response_timeout.unwrap_or(RtuTiming::over_tcp().response_timeout),
                ..RtuTiming::over_tcp()
            },
        ),
        Line::Emulated(_) => return Err(DeviceError::Config("an emulated gripper has no RTU line".into())),
    };
    let link = RtuLink::open(connector, timing, c.slave).map_err(|e| match e {
        // A forwarder not up yet, a port that appears later: the device may come up by itself.
        TransportError::NotFound { .. } | TransportError::Io(_) => DeviceError::transient(e),
        _ => DeviceError::link(e),
    })?;
    Ok(Box::new(link))
}
