//! The two DDS Security documents the keystore writes (OMG DDS Security 1.1, §9.4.1, elements
//! in the order of its XSDs), and the little reading of them `list`, `renew` and the doctor
//! need. The documents are handgate's own and SROS2's: elements without attributes of
//! interest, no nesting of an element in itself, so a reader of elements by name suffices.

use super::time::{xml_date, Unix};

/// The largest domain id CycloneDDS 0.10.2 accepts in a governance or permissions document
/// (measured: `<max>231</max>` or `<id>232</id>` makes it refuse the governance as
/// unparseable, code 137; 230 is accepted).
pub const MAX_DOMAIN: u32 = 230;

/// What an identity may do on its robots' domains (docs/security-keystore.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// A robot's gateway: publishes and subscribes every topic (it serves the robot's clients).
    Gateway,
    /// Commands the robots: publishes every front's command topics and the ROS 2 bookkeeping,
    /// subscribes everything.
    Operator,
    /// Reads only: subscribes everything, publishes only the ROS 2 bookkeeping.
    Observer,
}

impl Role {
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Gateway => "gateway",
            Role::Operator => "operator",
            Role::Observer => "observer",
        }
    }

    /// The topics it may publish (patterns). `commands`: the fronts' command topic patterns
    /// (`handgate_adapters::fronts::command_topic_patterns`).
    pub fn publishes(self, commands: &[String]) -> Vec<String> {
        let bookkeeping = handgate_adapters::fronts::ROS_BOOKKEEPING_TOPICS
            .iter()
            .map(|s| s.to_string());
        match self {
            Role::Gateway => vec!["*".into()],
            Role::Operator => commands.iter().cloned().chain(bookkeeping).collect(),
            Role::Observer => bookkeeping.collect(),
        }
    }

    /// The role whose publish list is `publish`; `None`: not one of handgate's (an SROS2
    /// policy's permissions, an edited document).
    pub fn recognise(publish: &[String], commands: &[String]) -> Option<Role> {
        [Role::Gateway, Role::Operator, Role::Observer].into_iter().find(|r| {
            let mut a = r.publishes(commands);
            let mut b = publish.to_vec();
            a.sort();
            b.sort();
            a == b
        })
    }
}

/// The domains of a grant.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Domains {
    /// These ids.
    Ids(Vec<u32>),
    /// Every domain CycloneDDS accepts (0..=[`MAX_DOMAIN`]).
    All,
}

impl Domains {
    fn xml(&self, indent: &str) -> String {
        match self {
            Domains::All => format!("{indent}<id_range><min>0</min><max>{MAX_DOMAIN}</max></id_range>\n"),
            Domains::Ids(ids) => ids.iter().map(|id| format!("{indent}<id>{id}</id>\n")).collect(),
        }
    }
}

/// `&`, `<`, `>`, `"`, `'` escaped.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

const GOVERNANCE_XSD: &str = "http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd";
const PERMISSIONS_XSD: &str = "http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd";

/// The lab's governance: one domain rule for every domain; only authenticated participants,
/// whose permissions must grant the domain; discovery and liveliness encrypted; every topic
/// with read and write access control and its data and metadata encrypted.
/// `enable_liveliness_protection` is present (CycloneDDS 0.10.2 refuses a topic rule without
/// it).
pub fn governance() -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="{GOVERNANCE_XSD}">
  <domain_access_rules>
    <domain_rule>
      <domains>
{domains}      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>false</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
"#,
        domains = Domains::All.xml("        ")
    )
}

/// One identity's grant as the keystore writes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Grant {
    /// The grant's name: the enclave (`/robot_a`).
    pub name: String,
    /// The certificate's subject as CycloneDDS compares it (`CN=/robot_a`).
    pub subject: String,
    /// The certificate's validity.
    pub not_before: Unix,
    pub not_after: Unix,
    pub domains: Domains,
    pub role: Role,
}

fn topics(list: &[String], indent: &str) -> String {
    list.iter()
        .map(|t| format!("{indent}<topic>{}</topic>\n", escape(t)))
        .collect()
}

/// The permissions document of `g`: `<default>DENY</default>`, one allow rule on its domains
/// publishing what its role may, subscribing everything. `commands`: the fronts' command topic
/// patterns.
pub fn permissions(g: &Grant, commands: &[String]) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="{PERMISSIONS_XSD}">
  <permissions>
    <grant name="{name}">
      <subject_name>{subject}</subject_name>
      <validity>
        <not_before>{nb}</not_before>
        <not_after>{na}</not_after>
      </validity>
      <allow_rule>
        <domains>
{domains}        </domains>
        <publish>
          <topics>
{publish}          </topics>
        </publish>
        <subscribe>
          <topics>
            <topic>*</topic>
          </topics>
        </subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
"#,
        name = escape(&g.name),
        subject = escape(&g.subject),
        nb = xml_date(g.not_before),
        na = xml_date(g.not_after),
        domains = g.domains.xml("          "),
        publish = topics(&g.role.publishes(commands), "            "),
    )
}

/// The inner text of every `<tag ...>...</tag>` in `xml` (comments removed first), in order.
pub fn elements<'a>(xml: &'a str, tag: &str) -> Vec<&'a str> {
    let open = format!("<{tag}");
    let close = format!("</{tag}>");
    let mut out = Vec::new();
    let mut rest = xml;
    while let Some(i) = rest.find(&open) {
        let after = &rest[i + open.len()..];
        // `<tag>` or `<tag attr...>`, not `<tag_longer>`.
        if !after.starts_with(['>', ' ', '\t', '\n', '\r', '/']) {
            rest = after;
            continue;
        }
        let Some(gt) = after.find('>') else { break };
        if after[..gt].ends_with('/') {
            out.push("");
            rest = &after[gt + 1..];
            continue;
        }
        let body = &after[gt + 1..];
        let Some(end) = body.find(&close) else { break };
        out.push(&body[..end]);
        rest = &body[end + close.len()..];
    }
    out
}

/// The value of attribute `attr` in the first `<tag ...>` of `xml`.
fn attribute(xml: &str, tag: &str, attr: &str) -> Option<String> {
    let i = xml.find(&format!("<{tag} "))?;
    let head = &xml[i..i + xml[i..].find('>')?];
    let key = format!("{attr}=");
    let j = head.find(&key)? + key.len();
    let q = head[j..].chars().next()?;
    let v = &head[j + 1..];
    Some(unescape(&v[..v.find(q)?]))
}

/// `xml` without its comments.
pub fn strip_comments(xml: &str) -> String {
    let mut out = String::with_capacity(xml.len());
    let mut rest = xml;
    while let Some(i) = rest.find("<!--") {
        out.push_str(&rest[..i]);
        match rest[i..].find("-->") {
            Some(j) => rest = &rest[i + j + 3..],
            None => return out,
        }
    }
    out.push_str(rest);
    out
}

/// Domain ids as a document lists them: `<id>` and `<id_range>` (a range without `max` is
/// open-ended).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DomainSet(pub Vec<(u32, Option<u32>)>);

impl DomainSet {
    fn read(domains: &str) -> Self {
        let num = |s: &str| s.trim().parse::<u32>().ok();
        let mut v = Vec::new();
        for id in elements(domains, "id").into_iter().filter_map(num) {
            v.push((id, Some(id)));
        }
        for r in elements(domains, "id_range") {
            let min = elements(r, "min").first().and_then(|s| num(s)).unwrap_or(0);
            let max = elements(r, "max").first().and_then(|s| num(s));
            v.push((min, max));
        }
        DomainSet(v)
    }

    pub fn contains(&self, domain: u32) -> bool {
        self.0
            .iter()
            .any(|&(lo, hi)| domain >= lo && hi.map_or(true, |h| domain <= h))
    }

    /// `11, 12` or `0-230`.
    pub fn describe(&self) -> String {
        let v: Vec<String> = self
            .0
            .iter()
            .map(|&(lo, hi)| match hi {
                Some(h) if h == lo => lo.to_string(),
                Some(h) => format!("{lo}-{h}"),
                None => format!("{lo}-"),
            })
            .collect();
        v.join(", ")
    }

    /// The single ids listed (`None` when a range is listed).
    pub fn ids(&self) -> Option<Vec<u32>> {
        self.0.iter().map(|&(lo, hi)| (hi == Some(lo)).then_some(lo)).collect()
    }
}

/// One allow or deny rule of a grant.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rule {
    pub domains: DomainSet,
    pub publish: Vec<String>,
    pub subscribe: Vec<String>,
}

/// One grant as read from a permissions document.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadGrant {
    pub name: Option<String>,
    pub subject: String,
    pub not_before: Option<String>,
    pub not_after: Option<String>,
    pub allow: Vec<Rule>,
    pub deny: Vec<Rule>,
    pub default: String,
}

fn rule(body: &str) -> Rule {
    let topics_of = |kind: &str| -> Vec<String> {
        elements(body, kind)
            .into_iter()
            .flat_map(|p| elements(p, "topic"))
            .map(|t| unescape(t.trim()))
            .collect()
    };
    Rule {
        domains: DomainSet::read(elements(body, "domains").first().copied().unwrap_or("")),
        publish: topics_of("publish"),
        subscribe: topics_of("subscribe"),
    }
}

/// The grants of a permissions document.
pub fn read_permissions(xml: &str) -> Vec<ReadGrant> {
    let xml = strip_comments(xml);
    let mut out = Vec::new();
    let mut rest = xml.as_str();
    while let Some(i) = rest.find("<grant") {
        let from = &rest[i..];
        let Some(end) = from.find("</grant>") else { break };
        let g = &from[..end];
        let first = |tag: &str| elements(g, tag).first().map(|s| unescape(s.trim()));
        out.push(ReadGrant {
            name: attribute(g, "grant", "name"),
            subject: first("subject_name").unwrap_or_default(),
            not_before: first("not_before"),
            not_after: first("not_after"),
            allow: elements(g, "allow_rule").into_iter().map(rule).collect(),
            deny: elements(g, "deny_rule").into_iter().map(rule).collect(),
            default: first("default").unwrap_or_default(),
        });
        rest = &from[end + "</grant>".len()..];
    }
    out
}

/// The domains a governance document has a rule for.
pub fn governance_domains(xml: &str) -> DomainSet {
    let xml = strip_comments(xml);
    DomainSet(
        elements(&xml, "domain_rule")
            .into_iter()
            .flat_map(|r| DomainSet::read(elements(r, "domains").first().copied().unwrap_or("")).0)
            .collect(),
    )
}

/// Whether two subject names are the same name as CycloneDDS 0.10.2 compares them: its
/// access control plugin prints the certificate's subject in RFC 2253 form (`CN=/robot_a`)
/// and compares it attribute by attribute with the grant's `subject_name`; measured with
/// CycloneDDS: `CN=/robot_a` and OpenSSL's one-line `/CN=/robot_a` match a certificate of
/// subject `/robot_a`, `CN=robot_a` and `CN=/other` do not. Here: equal as sets of
/// `attribute=value` after splitting at `,`, or equal to the one-line form.
pub fn same_subject(grant: &str, certificate_rfc2253: &str) -> bool {
    let set = |s: &str| -> Vec<String> {
        let mut v: Vec<String> = s
            .split(',')
            .map(|p| p.trim().to_string())
            .filter(|p| !p.is_empty())
            .collect();
        v.sort();
        v
    };
    let grant = grant.trim();
    if set(grant) == set(certificate_rfc2253) {
        return true;
    }
    // The one-line form of a single-attribute name: `/CN=/robot_a`.
    !certificate_rfc2253.contains(',') && grant.strip_prefix('/') == Some(certificate_rfc2253)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn commands() -> Vec<String> {
        vec!["rt/dex3/left/cmd".into(), "rt/handgate/*/cmd".into()]
    }

    fn grant(role: Role, domains: Domains) -> Grant {
        Grant {
            name: "/robot_a".into(),
            subject: "CN=/robot_a".into(),
            not_before: 1_795_955_223,
            not_after: 1_795_955_223 + 86_400,
            domains,
            role,
        }
    }

    #[test]
    fn governance_covers_every_domain_in_xsd_order() {
        let g = governance();
        assert!(g.contains("<id_range><min>0</min><max>230</max></id_range>"));
        assert!(governance_domains(&g).contains(0) && governance_domains(&g).contains(230));
        assert!(!governance_domains(&g).contains(231));
        let order = [
            "<domains>",
            "<allow_unauthenticated_participants>false",
            "<enable_join_access_control>true",
            "<discovery_protection_kind>ENCRYPT",
            "<liveliness_protection_kind>ENCRYPT",
            "<rtps_protection_kind>NONE",
            "<topic_expression>*",
            "<enable_discovery_protection>true",
            "<enable_liveliness_protection>false",
            "<enable_read_access_control>true",
            "<enable_write_access_control>true",
            "<metadata_protection_kind>ENCRYPT",
            "<data_protection_kind>ENCRYPT",
        ];
        let at: Vec<usize> = order
            .iter()
            .map(|e| g.find(e).unwrap_or_else(|| panic!("{e}")))
            .collect();
        assert!(at.windows(2).all(|w| w[0] < w[1]), "{at:?}");
    }

    #[test]
    fn permissions_per_role() {
        let c = commands();
        let gw = permissions(&grant(Role::Gateway, Domains::Ids(vec![11, 12])), &c);
        let read = read_permissions(&gw);
        assert_eq!(read.len(), 1);
        let r = &read[0];
        assert_eq!(
            (r.name.as_deref(), r.subject.as_str()),
            (Some("/robot_a"), "CN=/robot_a")
        );
        assert_eq!(r.not_before.as_deref(), Some("2026-11-29T12:27:03"));
        assert_eq!(r.not_after.as_deref(), Some("2026-11-30T12:27:03"));
        assert_eq!(r.default, "DENY");
        assert_eq!(r.allow.len(), 1);
        assert_eq!(r.allow[0].domains.ids(), Some(vec![11, 12]));
        assert_eq!(r.allow[0].publish, vec!["*"]);
        assert_eq!(r.allow[0].subscribe, vec!["*"]);
        assert_eq!(Role::recognise(&r.allow[0].publish, &c), Some(Role::Gateway));

        let op = read_permissions(&permissions(&grant(Role::Operator, Domains::Ids(vec![11])), &c));
        let p = &op[0].allow[0].publish;
        assert!(p.contains(&"rt/dex3/left/cmd".to_string()) && p.contains(&"ros_discovery_info".to_string()));
        assert!(!p.contains(&"*".to_string()));
        assert_eq!(Role::recognise(p, &c), Some(Role::Operator));

        let ob = read_permissions(&permissions(&grant(Role::Observer, Domains::All), &c));
        let rule = &ob[0].allow[0];
        assert_eq!(
            rule.publish,
            vec!["ros_discovery_info", "rt/rosout", "rt/parameter_events"]
        );
        assert_eq!(rule.subscribe, vec!["*"]);
        assert!(rule.domains.contains(230) && !rule.domains.contains(231));
        assert_eq!(rule.domains.describe(), "0-230");
        assert_eq!(Role::recognise(&rule.publish, &c), Some(Role::Observer));
        // Another set of topics is nobody's role.
        assert_eq!(Role::recognise(&["rt/chatter".to_string()], &c), None);
    }

    #[test]
    fn permissions_element_order_and_escaping() {
        let mut g = grant(Role::Gateway, Domains::Ids(vec![11]));
        g.subject = "CN=a&b,O=<lab>".into();
        let x = permissions(&g, &commands());
        assert!(x.contains("<subject_name>CN=a&amp;b,O=&lt;lab&gt;</subject_name>"));
        assert_eq!(read_permissions(&x)[0].subject, "CN=a&b,O=<lab>");
        let order = [
            "<subject_name>",
            "<validity>",
            "<allow_rule>",
            "<domains>",
            "<publish>",
            "<subscribe>",
            "<default>",
        ];
        let at: Vec<usize> = order.iter().map(|e| x.find(e).unwrap()).collect();
        assert!(at.windows(2).all(|w| w[0] < w[1]), "{at:?}");
    }

    #[test]
    fn reads_sros2_style_documents() {
        let x = r#"<dds><permissions>
  <!-- <grant name="commented"> -->
  <grant name="/talker_listener/talker">
    <subject_name>CN=/talker_listener/talker</subject_name>
    <validity><not_before>2021-06-18T00:00:00</not_before><not_after>2031-06-18T00:00:00</not_after></validity>
    <allow_rule><domains><id>0</id><id_range><min>100</min></id_range></domains>
      <publish><topics><topic>rt/chatter</topic></topics></publish>
    </allow_rule>
    <deny_rule><domains><id>5</id></domains><subscribe><topics><topic>*</topic></topics></subscribe></deny_rule>
    <default>DENY</default>
  </grant></permissions></dds>"#;
        let g = read_permissions(x);
        assert_eq!(g.len(), 1);
        assert_eq!(g[0].name.as_deref(), Some("/talker_listener/talker"));
        assert!(g[0].allow[0].domains.contains(0) && g[0].allow[0].domains.contains(200));
        assert!(!g[0].allow[0].domains.contains(5));
        assert_eq!(g[0].allow[0].domains.ids(), None);
        assert_eq!(g[0].deny.len(), 1);
        assert_eq!(g[0].allow[0].publish, vec!["rt/chatter"]);
    }

    #[test]
    fn subjects_compare_as_cyclonedds_does() {
        assert!(same_subject("CN=/robot_a", "CN=/robot_a"));
        assert!(same_subject("/CN=/robot_a", "CN=/robot_a"));
        assert!(same_subject("O=lab, CN=x", "CN=x,O=lab"));
        assert!(!same_subject("CN=robot_a", "CN=/robot_a"));
        assert!(!same_subject("CN=/other", "CN=/robot_a"));
        assert!(!same_subject("CN=/robot_a,O=lab", "CN=/robot_a"));
    }
}
