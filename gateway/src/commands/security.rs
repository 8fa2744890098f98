//! `handgate security`: the lab's keystore (`handgate_gateway::security::keystore`).

use std::process::ExitCode;

use anyhow::Context;
use handgate_gateway::cli::SecurityCmd;
use handgate_gateway::security::keystore::{IssueRequest, Keystore, San, Validity};
use handgate_gateway::security::time;
use handgate_gateway::security::SecurityError;

pub fn security(cmd: SecurityCmd) -> anyhow::Result<ExitCode> {
    let now = time::now();
    match cmd {
        SecurityCmd::Init { keystore, name, days } => {
            let ks = Keystore::init(&std::path::absolute(&keystore.keystore)?, &name, days, now)?;
            println!(
                "keystore {} created: CA \"{name}\", valid {days} days",
                ks.dir.display()
            );
            println!("  CA certificate   {}", ks.ca_cert().display());
            println!("  governance       {}", ks.governance().display());
            println!("  revocation list  {}", ks.crl().display());
            println!(
                "issue identities with `handgate security issue --keystore {} NAME --role ...`",
                ks.dir.display()
            );
        }
        SecurityCmd::Issue {
            keystore,
            name,
            role,
            robots,
            days,
            not_before,
            not_after,
            sans,
        } => {
            let ks = Keystore::open(&std::path::absolute(&keystore.keystore)?)?;
            let validity = match (not_before, not_after) {
                (Some(nb), Some(na)) => Validity::Span {
                    not_before: parse_time("--not-before", &nb)?,
                    not_after: parse_time("--not-after", &na)?,
                },
                _ => Validity::Days(days),
            };
            let sans = sans.iter().map(|s| San::parse(s)).collect::<Result<Vec<_>, _>>()?;
            let req = IssueRequest {
                name,
                role: role.into(),
                robots,
                validity,
                sans,
            };
            let issued = ks.issue(&req, now).with_context(|| format!("issuing {}", req.name))?;
            print_issued("issued", &issued);
        }
        SecurityCmd::Revoke { keystore, name } => {
            let ks = Keystore::open(&std::path::absolute(&keystore.keystore)?)?;
            let serials = ks.revoke(&name, now)?;
            if serials.is_empty() {
                println!("{name}: already revoked; {} unchanged", ks.crl().display());
            } else {
                println!(
                    "{name}: revoked certificate serial {}; give {} to every participant (`crl` in its security section)",
                    serials.join(", "),
                    ks.crl().display()
                );
            }
        }
        SecurityCmd::Renew { keystore, name, days } => {
            let ks = Keystore::open(&std::path::absolute(&keystore.keystore)?)?;
            let issued = ks.renew(&name, days, now)?;
            print_issued("renewed", &issued);
            println!("  the previous certificate keeps working until it expires; revoke it with `handgate security revoke` if it must stop");
        }
        SecurityCmd::List { keystore } => {
            let ks = Keystore::open(&std::path::absolute(&keystore.keystore)?)?;
            let rows = ks.list()?;
            if rows.is_empty() {
                println!("no enclaves in {}", ks.enclaves().display());
            }
            let width = rows.iter().map(|r| r.name.len()).max().unwrap_or(0).max(7);
            let swidth = rows.iter().map(|r| r.subject.len()).max().unwrap_or(0).max(7);
            if !rows.is_empty() {
                println!(
                    "{:width$}  {:swidth$}  {:8}  {:10}  {:20}  {:20}  STATUS",
                    "ENCLAVE", "SUBJECT", "ROLE", "ROBOTS", "NOT BEFORE", "NOT AFTER"
                );
            }
            for r in rows {
                let status = if r.revoked {
                    "revoked"
                } else if now >= r.not_after {
                    "expired"
                } else if now < r.not_before {
                    "not yet valid"
                } else {
                    "valid"
                };
                println!(
                    "{:width$}  {:swidth$}  {:8}  {:10}  {:20}  {:20}  {status}",
                    r.name,
                    r.subject,
                    r.role.map(|r| r.as_str()).unwrap_or("other"),
                    r.robots,
                    time::rfc3339(r.not_before),
                    time::rfc3339(r.not_after),
                );
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn parse_time(what: &'static str, s: &str) -> Result<time::Unix, SecurityError> {
    time::parse(s).ok_or_else(|| SecurityError::BadTime {
        what,
        value: s.to_string(),
    })
}

fn print_issued(verb: &str, i: &handgate_gateway::security::keystore::Issued) {
    println!(
        "{verb} {}: subject {}, serial {}, valid {} to {}",
        i.name,
        i.cert.subject,
        i.cert.serial,
        time::rfc3339(i.cert.not_before),
        time::rfc3339(i.cert.not_after)
    );
    println!("  enclave {}", i.dir.display());
}
