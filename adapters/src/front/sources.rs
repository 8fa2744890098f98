//! Who may command a front, by network address (`[export] allow_commands_from`): DDS here has
//! no authentication (Debian's CycloneDDS is built without DDS Security), so on a shared lab
//! network any participant could write a front's command topic. Discovery knows each
//! participant's locators (`__NetworkAddresses`); a command whose writer's participant has no
//! address in the list is refused, states still flow to everyone. This stops a stray or
//! misconfigured client; it does not stop one that forges its address (docs/deployment.md,
//! "Who may command").

use std::net::IpAddr;

use crate::dds::WriterInfo;
use crate::discovery::Snapshot;

/// One entry: an address, or a network `ADDR/PREFIX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Net {
    addr: IpAddr,
    prefix: u8,
}

impl Net {
    /// `10.0.0.5`, `10.0.0.0/24`, `fd00::/8`.
    pub fn parse(s: &str) -> Result<Net, String> {
        let (a, p) = match s.split_once('/') {
            Some((a, p)) => (a, Some(p)),
            None => (s, None),
        };
        let addr: IpAddr = a
            .trim()
            .parse()
            .map_err(|_| format!("`{s}` is not an address or ADDRESS/PREFIX"))?;
        let max = if addr.is_ipv4() { 32 } else { 128 };
        let prefix = match p {
            None => max,
            Some(p) => p
                .trim()
                .parse::<u8>()
                .ok()
                .filter(|p| *p <= max)
                .ok_or_else(|| format!("`{s}`: the prefix must be 0..={max}"))?,
        };
        Ok(Net { addr, prefix })
    }

    pub fn contains(&self, ip: IpAddr) -> bool {
        let bits = |ip: IpAddr| -> (u128, u32) {
            match ip {
                IpAddr::V4(v) => (u128::from(u32::from(v)) << 96, 32),
                IpAddr::V6(v) => (u128::from(v), 128),
            }
        };
        let ((net, width), (x, w)) = (bits(self.addr), bits(ip));
        if width != w {
            return false;
        }
        let mask = if self.prefix == 0 {
            0
        } else {
            u128::MAX << (128 - u32::from(self.prefix))
        };
        net & mask == x & mask
    }
}

/// What the list says about a writer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// One of its participant's addresses is listed (or it is no DDS writer: a dashboard page).
    Allowed,
    /// None of these addresses is listed.
    Refused(Vec<IpAddr>),
    /// Discovery does not know its participant (yet): refused, asked again next time.
    Unknown,
}

/// The allow-list of one export side.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Sources(Vec<Net>);

impl Sources {
    pub fn new(nets: Vec<Net>) -> Sources {
        Sources(nets)
    }

    pub fn admits(&self, ip: IpAddr) -> bool {
        self.0.iter().any(|n| n.contains(ip))
    }

    /// The verdict on `writer`, whose participant's addresses discovery reports in `snap`.
    pub fn judge(&self, writer: &WriterInfo, snap: &Snapshot) -> Verdict {
        if writer.label.is_some() {
            return Verdict::Allowed;
        }
        let Some(p) = writer.participant.and_then(|g| snap.participant(&g)) else {
            return Verdict::Unknown;
        };
        let ips: Vec<IpAddr> = p.ip_addresses().collect();
        if ips.iter().any(|ip| self.admits(*ip)) {
            Verdict::Allowed
        } else {
            Verdict::Refused(ips)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_and_networks() {
        let s = Sources::new(vec![
            Net::parse("10.229.0.100").unwrap(),
            Net::parse("192.168.50.0/24").unwrap(),
        ]);
        for (ip, ok) in [
            ("10.229.0.100", true),
            ("10.229.0.101", false),
            ("192.168.50.7", true),
            ("192.168.51.7", false),
            ("::1", false),
        ] {
            assert_eq!(s.admits(ip.parse().unwrap()), ok, "{ip}");
        }
        let any = Sources::new(vec![Net::parse("0.0.0.0/0").unwrap()]);
        assert!(any.admits("8.8.8.8".parse().unwrap()) && !any.admits("::1".parse().unwrap()));
        assert!(Sources::new(vec![Net::parse("fd00::/8").unwrap()]).admits("fd12::3".parse().unwrap()));
        for bad in ["10.0.0", "10.0.0.0/33", "fd00::/129", "host", "10.0.0.1/x"] {
            assert!(Net::parse(bad).is_err(), "{bad}");
        }
    }
}
