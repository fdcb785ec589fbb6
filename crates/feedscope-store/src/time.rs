//! RFC 3339 time stamps to and from seconds since the Unix epoch (UTC), without a calendar
//! crate: the day counts of [`feedscope::calendar`].

use feedscope::calendar::{civil_from_days, days_from_civil};

/// Parse `YYYY-MM-DDTHH:MM:SS[.frac](Z|±HH:MM)` (also with a space or `t` for `T`, `z` for
/// `Z`) to seconds since the Unix epoch.
pub fn parse_rfc3339(s: &str) -> Option<f64> {
    let b = s.as_bytes();
    if b.len() < 20 {
        return None;
    }
    let num = |r: std::ops::Range<usize>| -> Option<i64> {
        let t = s.get(r)?;
        t.bytes()
            .all(|c| c.is_ascii_digit())
            .then(|| t.parse().ok())?
    };
    let (y, mo, d) = (num(0..4)?, num(5..7)?, num(8..10)?);
    if b[4] != b'-' || b[7] != b'-' || !matches!(b[10], b'T' | b't' | b' ') {
        return None;
    }
    let (h, mi, se) = (num(11..13)?, num(14..16)?, num(17..19)?);
    if b[13] != b':' || b[16] != b':' {
        return None;
    }
    if !(1..=12).contains(&mo) || !(1..=31).contains(&d) || h > 23 || mi > 59 || se > 60 {
        return None;
    }
    let mut i = 19;
    let mut frac = 0.0;
    if b[i] == b'.' {
        let start = i + 1;
        i = start;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        if i == start {
            return None;
        }
        frac = format!("0.{}", &s[start..i]).parse().ok()?;
    }
    let offset_s = match b.get(i)? {
        b'Z' | b'z' if i + 1 == b.len() => 0,
        c @ (b'+' | b'-') if i + 6 == b.len() && b[i + 3] == b':' => {
            let (oh, om) = (num(i + 1..i + 3)?, num(i + 4..i + 6)?);
            let o = oh * 3600 + om * 60;
            if *c == b'+' {
                o
            } else {
                -o
            }
        }
        _ => return None,
    };
    let days = days_from_civil(y, mo, d);
    Some((days * 86_400 + h * 3600 + mi * 60 + se - offset_s) as f64 + frac)
}

/// Format seconds since the Unix epoch as `YYYY-MM-DDTHH:MM:SSZ` (whole seconds, rounded
/// down).
pub fn format_rfc3339(t_s: f64) -> String {
    let t = t_s.floor() as i64;
    let (days, sod) = (t.div_euclid(86_400), t.rem_euclid(86_400));
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        sod / 3600,
        sod / 60 % 60,
        sod % 60
    )
}

/// Now, seconds since the Unix epoch.
pub fn now_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_instants() {
        // 2000-03-01T00:00:00Z = 951868800 (date -d @951868800 -u)
        assert_eq!(parse_rfc3339("2000-03-01T00:00:00Z"), Some(951_868_800.0));
        assert_eq!(
            parse_rfc3339("2026-11-21T15:00:00+01:00"),
            parse_rfc3339("2026-11-21T14:00:00Z")
        );
        let t = parse_rfc3339("2024-02-29T23:59:59.25Z").unwrap();
        assert_eq!(format_rfc3339(t), "2024-02-29T23:59:59Z");
        assert_eq!(format_rfc3339(0.0), "1970-01-01T00:00:00Z");
        for bad in [
            "2024-13-01T00:00:00Z",
            "2024-01-01 00:00:00",
            "yesterday",
            "2024-01-01T00:00:00.Z",
        ] {
            assert_eq!(parse_rfc3339(bad), None, "{bad}");
        }
    }

    #[test]
    fn round_trip_over_centuries() {
        for k in -2000..2000 {
            let t = k as f64 * 1_234_567.0;
            assert_eq!(parse_rfc3339(&format_rfc3339(t)), Some(t), "{t}");
        }
    }
}
