//! This host's network interfaces (`getifaddrs`) and a multicast loopback probe, for telling a
//! user which interface DDS can use and whether multicast works on it.

use std::ffi::CStr;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddrV4, UdpSocket};
use std::os::fd::AsRawFd;
use std::time::{Duration, Instant};

/// One address of an interface, with its prefix length.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IfAddr {
    pub ip: IpAddr,
    pub prefix: u8,
}

impl IfAddr {
    /// Whether `ip` is on this address's subnet.
    pub fn contains(&self, ip: IpAddr) -> bool {
        match (self.ip, ip) {
            (IpAddr::V4(a), IpAddr::V4(b)) => {
                let mask = u32::MAX.checked_shl(32 - u32::from(self.prefix.min(32))).unwrap_or(0);
                u32::from(a) & mask == u32::from(b) & mask
            }
            (IpAddr::V6(a), IpAddr::V6(b)) => {
                let mask = u128::MAX
                    .checked_shl(128 - u32::from(self.prefix.min(128)))
                    .unwrap_or(0);
                u128::from(a) & mask == u128::from(b) & mask
            }
            _ => false,
        }
    }
}

/// A network interface of this host.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NetIf {
    pub name: String,
    pub up: bool,
    pub loopback: bool,
    pub multicast: bool,
    pub addrs: Vec<IfAddr>,
}

impl NetIf {
    /// The first IPv4 address.
    pub fn ipv4(&self) -> Option<Ipv4Addr> {
        self.addrs.iter().find_map(|a| match a.ip {
            IpAddr::V4(v4) => Some(v4),
            IpAddr::V6(_) => None,
        })
    }

    /// Whether `ip` is on one of this interface's subnets.
    pub fn on_subnet(&self, ip: IpAddr) -> bool {
        self.addrs.iter().any(|a| a.contains(ip))
    }
}

fn prefix_len(bytes: &[u8]) -> u8 {
    bytes.iter().map(|b| b.count_ones() as u8).sum()
}

/// # Safety
/// `sa` is null or points to a valid `sockaddr` of its family's size.
unsafe fn sockaddr_ip(sa: *const libc::sockaddr) -> Option<IpAddr> {
    if sa.is_null() {
        return None;
    }
    // SAFETY: non-null and valid per the caller; the family says which struct it is.
    unsafe {
        match i32::from((*sa).sa_family) {
            libc::AF_INET => {
                let sin = &*(sa as *const libc::sockaddr_in);
                Some(IpAddr::V4(Ipv4Addr::from(u32::from_be(sin.sin_addr.s_addr))))
            }
            libc::AF_INET6 => {
                let sin6 = &*(sa as *const libc::sockaddr_in6);
                Some(IpAddr::V6(Ipv6Addr::from(sin6.sin6_addr.s6_addr)))
            }
            _ => None,
        }
    }
}

/// This host's interfaces, in the order the kernel lists them.
pub fn list() -> std::io::Result<Vec<NetIf>> {
    let mut head: *mut libc::ifaddrs = std::ptr::null_mut();
    // SAFETY: `head` is an out-parameter; freed below with freeifaddrs.
    if unsafe { libc::getifaddrs(&mut head) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    let mut out: Vec<NetIf> = Vec::new();
    let mut cur = head;
    while !cur.is_null() {
        // SAFETY: a node of the list getifaddrs returned, alive until freeifaddrs.
        let ifa = unsafe { &*cur };
        cur = ifa.ifa_next;
        if ifa.ifa_name.is_null() {
            continue;
        }
        // SAFETY: a NUL-terminated interface name from the kernel.
        let name = unsafe { CStr::from_ptr(ifa.ifa_name) }.to_string_lossy().into_owned();
        let flags = ifa.ifa_flags;
        let idx = match out.iter().position(|i| i.name == name) {
            Some(i) => i,
            None => {
                out.push(NetIf {
                    name,
                    up: flags & libc::IFF_UP as u32 != 0,
                    loopback: flags & libc::IFF_LOOPBACK as u32 != 0,
                    multicast: flags & libc::IFF_MULTICAST as u32 != 0,
                    addrs: Vec::new(),
                });
                out.len() - 1
            }
        };
        // SAFETY: the address and netmask are null or valid sockaddrs of their family.
        let (ip, mask) = unsafe { (sockaddr_ip(ifa.ifa_addr), sockaddr_ip(ifa.ifa_netmask)) };
        if let Some(ip) = ip {
            let prefix = match mask {
                Some(IpAddr::V4(m)) => prefix_len(&m.octets()),
                Some(IpAddr::V6(m)) => prefix_len(&m.octets()),
                None => 0,
            };
            out[idx].addrs.push(IfAddr { ip, prefix });
        }
    }
    // SAFETY: the list getifaddrs allocated, freed once.
    unsafe { libc::freeifaddrs(head) };
    Ok(out)
}

/// A multicast group and port for [`multicast_loopback_probe`]: administratively scoped
/// (239/8) like CycloneDDS's SPDP group 239.255.0.1, on a port outside CycloneDDS's port
/// mapping (7400 + 250 × domain + …) for domains 0–232.
pub const PROBE_GROUP: Ipv4Addr = Ipv4Addr::new(239, 255, 0, 87);

/// Sends one datagram to a multicast group out of the interface with IPv4 address `iface`
/// (`IP_MULTICAST_IF`, loopback on) and waits up to `timeout` to receive it on a socket that
/// joined the group on that interface. `Ok(round trip)` proves the interface is up, accepts
/// the group membership and the kernel routes multicast through it; it does not prove that
/// the network beyond it (a switch, another host's firewall) forwards multicast.
pub fn multicast_loopback_probe(iface: Ipv4Addr, timeout: Duration) -> Result<Duration, String> {
    let rx = UdpSocket::bind(SocketAddrV4::new(Ipv4Addr::UNSPECIFIED, 0)).map_err(|e| format!("bind: {e}"))?;
    let port = rx.local_addr().map_err(|e| e.to_string())?.port();
    rx.join_multicast_v4(&PROBE_GROUP, &iface)
        .map_err(|e| format!("joining {PROBE_GROUP} on {iface}: {e}"))?;
    rx.set_read_timeout(Some(timeout)).map_err(|e| e.to_string())?;
    let tx = UdpSocket::bind(SocketAddrV4::new(iface, 0)).map_err(|e| format!("bind {iface}: {e}"))?;
    tx.set_multicast_loop_v4(true).map_err(|e| e.to_string())?;
    let addr = libc::in_addr {
        s_addr: u32::from(iface).to_be(),
    };
    // SAFETY: a live socket; `addr` is an in_addr of the size passed.
    let rc = unsafe {
        libc::setsockopt(
            tx.as_raw_fd(),
            libc::IPPROTO_IP,
            libc::IP_MULTICAST_IF,
            (&addr as *const libc::in_addr).cast(),
            std::mem::size_of::<libc::in_addr>() as libc::socklen_t,
        )
    };
    if rc != 0 {
        return Err(format!("IP_MULTICAST_IF {iface}: {}", std::io::Error::last_os_error()));
    }
    let token: [u8; 16] = {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        (nanos ^ u128::from(std::process::id())).to_le_bytes()
    };
    let start = Instant::now();
    tx.send_to(&token, SocketAddrV4::new(PROBE_GROUP, port))
        .map_err(|e| format!("sending to {PROBE_GROUP}:{port} via {iface}: {e}"))?;
    let mut buf = [0u8; 64];
    loop {
        let left = timeout.saturating_sub(start.elapsed());
        if left.is_zero() {
            return Err(format!("no datagram came back within {timeout:?}"));
        }
        rx.set_read_timeout(Some(left)).map_err(|e| e.to_string())?;
        match rx.recv_from(&mut buf) {
            Ok((n, _)) if buf[..n] == token => return Ok(start.elapsed()),
            Ok(_) => continue, // someone else's datagram on the group
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                return Err(format!("no datagram came back within {timeout:?}"))
            }
            Err(e) => return Err(format!("receiving: {e}")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subnets() {
        let a = IfAddr {
            ip: "192.168.123.161".parse().unwrap(),
            prefix: 24,
        };
        assert!(a.contains("192.168.123.99".parse().unwrap()));
        assert!(!a.contains("192.168.124.99".parse().unwrap()));
        assert!(!a.contains("::1".parse().unwrap()));
        let any = IfAddr {
            ip: "10.0.0.1".parse().unwrap(),
            prefix: 0,
        };
        assert!(any.contains("1.2.3.4".parse().unwrap()));
        assert_eq!(prefix_len(&[255, 255, 240, 0]), 20);
    }

    #[test]
    fn lists_loopback_and_probes_it() {
        let ifs = list().unwrap();
        let lo = ifs.iter().find(|i| i.loopback).expect("a loopback interface");
        assert!(lo.up);
        assert!(lo.on_subnet("127.0.0.1".parse().unwrap()));
        // Linux routes multicast on lo only when it has the MULTICAST flag (often off).
        if let (Some(ip), true) = (lo.ipv4(), lo.multicast) {
            multicast_loopback_probe(ip, Duration::from_secs(1)).unwrap();
        }
    }
}
