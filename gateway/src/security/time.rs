//! Times as Unix seconds (UTC) and the three ways the keystore writes them: RFC 3339 (the
//! command line, `handgate security list`), ASN.1 GeneralizedTime (`openssl ca -startdate`)
//! and the DDS Security XML date (`<not_before>`, UTC without a zone, as SROS2 writes it).

/// Seconds since 1970-01-01T00:00:00Z.
pub type Unix = i64;

/// Now, as Unix seconds.
pub fn now() -> Unix {
    match std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH) {
        Ok(d) => d.as_secs() as i64,
        Err(e) => -(e.duration().as_secs() as i64),
    }
}

/// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
fn days_from_civil(y: i64, m: u32, d: u32) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let m = m as i64;
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + d as i64 - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The date of `z` days since 1970-01-01.
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { yoe + era * 400 + 1 } else { yoe + era * 400 }, m, d)
}

/// (year, month, day, hour, minute, second) of `t`.
fn fields(t: Unix) -> (i64, u32, u32, u32, u32, u32) {
    let (y, m, d) = civil_from_days(t.div_euclid(86_400));
    let s = t.rem_euclid(86_400) as u32;
    (y, m, d, s / 3600, s / 60 % 60, s % 60)
}

/// `2026-11-29T12:00:00Z`.
pub fn rfc3339(t: Unix) -> String {
    let (y, mo, d, h, mi, s) = fields(t);
    format!("{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}Z")
}

/// `2026-11-29T12:00:00`: the DDS Security permissions' date (UTC), as SROS2 writes it.
pub fn xml_date(t: Unix) -> String {
    let (y, mo, d, h, mi, s) = fields(t);
    format!("{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}")
}

/// `20261129120000Z`: ASN.1 GeneralizedTime, what `openssl ca -startdate/-enddate` take.
pub fn asn1(t: Unix) -> String {
    let (y, mo, d, h, mi, s) = fields(t);
    format!("{y:04}{mo:02}{d:02}{h:02}{mi:02}{s:02}Z")
}

/// Reads `YYYY-MM-DD[T ]HH:MM:SS[.frac][Z|±HH:MM|±HHMM]` (RFC 3339; OpenSSL's `-dateopt
/// iso_8601`; the permissions' dates, which have no zone and are UTC). `None` when it is not
/// one.
pub fn parse(s: &str) -> Option<Unix> {
    let s = s.trim();
    let b = s.as_bytes();
    let num = |from: usize, len: usize| -> Option<i64> {
        let part = s.get(from..from + len)?;
        part.bytes().all(|c| c.is_ascii_digit()).then(|| part.parse().ok())?
    };
    if b.len() < 19
        || b[4] != b'-'
        || b[7] != b'-'
        || !matches!(b[10], b'T' | b't' | b' ')
        || b[13] != b':'
        || b[16] != b':'
    {
        return None;
    }
    let (y, mo, d) = (num(0, 4)?, num(5, 2)?, num(8, 2)?);
    let (h, mi, sec) = (num(11, 2)?, num(14, 2)?, num(17, 2)?);
    if !(1..=12).contains(&mo) || !(1..=31).contains(&d) || h > 23 || mi > 59 || sec > 60 {
        return None;
    }
    let mut rest = &s[19..];
    if let Some(frac) = rest.strip_prefix('.') {
        let digits = frac.bytes().take_while(u8::is_ascii_digit).count();
        if digits == 0 {
            return None;
        }
        rest = &frac[digits..];
    }
    let offset = match rest {
        "" | "Z" | "z" => 0,
        _ => {
            let sign = match rest.as_bytes()[0] {
                b'+' => 1,
                b'-' => -1,
                _ => return None,
            };
            let z = rest[1..].replace(':', "");
            if z.len() != 4 || !z.bytes().all(|c| c.is_ascii_digit()) {
                return None;
            }
            let (oh, om): (i64, i64) = (z[..2].parse().ok()?, z[2..].parse().ok()?);
            sign * (oh * 3600 + om * 60)
        }
    };
    let days = days_from_civil(y, mo as u32, d as u32);
    Some(days * 86_400 + h * 3600 + mi * 60 + sec.min(59) - offset)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        for t in [0, 1_795_955_223, 4_102_444_800, 951_782_400 /* 2000-02-29 */] {
            assert_eq!(parse(&rfc3339(t)), Some(t));
            assert_eq!(parse(&xml_date(t)), Some(t));
        }
        assert_eq!(rfc3339(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(asn1(1_795_955_223), "20261129122703Z");
    }

    #[test]
    fn reads_zones_and_openssl() {
        assert_eq!(parse("2026-11-29T12:00:00+01:00"), parse("2026-11-29T11:00:00Z"));
        assert_eq!(parse("2026-11-29 12:00:00Z"), parse("2026-11-29T12:00:00Z"));
        assert_eq!(parse("2026-11-29T12:00:00.250-0030"), parse("2026-11-29T12:30:00Z"));
        assert_eq!(parse("2026-13-29T12:00:00Z"), None);
        assert_eq!(parse("2026-11-29"), None);
        assert_eq!(parse("2026-11-29T12:00:00 GMT"), None);
    }
}
