//! UTC → Julian date → sidereal time, and UTC as ISO 8601 text.
//!
//! The formulas are one line each (IAU 1982 GMST as given by Meeus, "Astronomical
//! Algorithms", eq. 12.4), so no time crate is needed. UTC stands in for UT1: the two
//! differ by under 0.9 s (0.0038° of sidereal time).

use std::time::{SystemTime, UNIX_EPOCH};

/// Julian date of the Unix epoch, 1970-01-01T00:00:00Z.
const JD_UNIX_EPOCH: f64 = 2_440_587.5;
/// J2000.0 (2000-01-01T12:00:00 TT, taken as UT).
const JD_J2000: f64 = 2_451_545.0;

/// Seconds since the Unix epoch now (negative before it).
pub fn unix_now() -> f64 {
    match SystemTime::now().duration_since(UNIX_EPOCH) {
        Ok(d) => d.as_secs_f64(),
        Err(e) => -e.duration().as_secs_f64(),
    }
}

pub fn julian_date(unix: f64) -> f64 {
    unix / 86_400.0 + JD_UNIX_EPOCH
}

/// Greenwich mean sidereal time (degrees in [0, 360)) at Julian date `jd` (UT):
/// Meeus eq. 12.4, the IAU 1982 expression.
pub fn gmst_deg(jd: f64) -> f64 {
    let d = jd - JD_J2000;
    let t = d / 36_525.0;
    let th =
        280.460_618_37 + 360.985_647_366_29 * d + 0.000_387_933 * t * t - t * t * t / 38_710_000.0;
    th.rem_euclid(360.0)
}

/// Local mean sidereal time (degrees in [0, 360)) at east longitude `lon_deg`.
pub fn lst_deg(unix: f64, lon_deg: f64) -> f64 {
    (gmst_deg(julian_date(unix)) + lon_deg).rem_euclid(360.0)
}

/// The civil date of a day count since 1970-01-01 (H. Hinnant, "chrono-Compatible
/// Low-Level Date Algorithms", civil_from_days).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

/// Days since 1970-01-01 of a civil date (H. Hinnant, days_from_civil).
fn days_from_civil(y: i64, m: u32, d: u32) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y.rem_euclid(400);
    let mp = (i64::from(m) + 9) % 12;
    let doy = (153 * mp + 2) / 5 + i64::from(d) - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Earliest and latest years a UTCDate may be set to: the span over which the IAU 1982
/// sidereal time is used (Meeus ch. 12 gives it for dates near J2000 ± 2 centuries).
pub const YEARS: (i64, i64) = (1900, 2199);

/// Seconds since the Unix epoch of an ISO 8601 UTC time, `YYYY-MM-DDTHH:MM:SS[.f…]`
/// followed by `Z` or an offset `±HH:MM` (the forms ASCOM and .NET write); a space
/// may stand before the zone. Years 1900 to 2199.
pub fn parse_iso8601(text: &str) -> Result<f64, String> {
    let bad = |why: &str| format!("'{text}' is not an ISO 8601 UTC time ({why})");
    let t = text.trim();
    let (date, rest) = t
        .split_once(['T', 't'])
        .ok_or_else(|| bad("no T between date and time"))?;
    let num = |s: &str, what: &str| -> Result<i64, String> {
        if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad(what));
        }
        s.parse::<i64>().map_err(|_| bad(what))
    };
    let d: Vec<&str> = date.split('-').collect();
    let [y, mo, da] = d[..] else {
        return Err(bad("the date is not YYYY-MM-DD"));
    };
    let (y, mo, da) = (num(y, "year")?, num(mo, "month")?, num(da, "day")?);
    // The zone: Z, or ±HH:MM (east of Greenwich positive).
    let (clock, offset) = if let Some(c) = rest.strip_suffix(['Z', 'z']) {
        (c.trim_end(), 0)
    } else if let Some(k) = rest.rfind(['+', '-']) {
        let (c, z) = rest.split_at(k);
        let sign = if z.starts_with('-') { -1 } else { 1 };
        let (hh, mm) = z[1..]
            .split_once(':')
            .ok_or_else(|| bad("offset not ±HH:MM"))?;
        let (hh, mm) = (num(hh, "offset hours")?, num(mm, "offset minutes")?);
        if hh > 23 || mm > 59 {
            return Err(bad("offset out of range"));
        }
        (c.trim_end(), sign * (hh * 3600 + mm * 60))
    } else {
        return Err(bad("no Z or ±HH:MM: the time must be UTC"));
    };
    let c: Vec<&str> = clock.split(':').collect();
    let [hh, mi, ss] = c[..] else {
        return Err(bad("the time is not HH:MM:SS"));
    };
    let (ss, frac) = ss.split_once('.').unwrap_or((ss, ""));
    let (hh, mi, ss) = (num(hh, "hour")?, num(mi, "minute")?, num(ss, "second")?);
    let frac = if frac.is_empty() {
        0.0
    } else {
        num(frac, "fraction of a second")?;
        format!("0.{frac}")
            .parse::<f64>()
            .map_err(|_| bad("fraction"))?
    };
    let month_days = [31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31];
    let leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    if !(YEARS.0..=YEARS.1).contains(&y) {
        return Err(bad(&format!("year outside {} to {}", YEARS.0, YEARS.1)));
    }
    let last = if (1..=12).contains(&mo) {
        month_days[mo as usize - 1] + i64::from(mo == 2 && leap)
    } else {
        return Err(bad("month outside 1 to 12"));
    };
    if !(1..=last).contains(&da) || hh > 23 || mi > 59 || ss > 59 {
        return Err(bad("a field is out of range"));
    }
    let days = days_from_civil(y, mo as u32, da as u32);
    Ok((days * 86_400 + hh * 3600 + mi * 60 + ss - offset) as f64 + frac)
}

/// `2026-12-04T16:15:12.1230000Z`: the ISO 8601 form ASCOM's UTCDate uses.
pub fn iso8601(unix: f64) -> String {
    let ticks = (unix * 1e7).round() as i64; // 100 ns, as .NET's DateTime
    let secs = ticks.div_euclid(10_000_000);
    let frac = ticks.rem_euclid(10_000_000);
    let (y, mo, d) = civil_from_days(secs.div_euclid(86_400));
    let s = secs.rem_euclid(86_400);
    format!(
        "{y:04}-{mo:02}-{d:02}T{:02}:{:02}:{:02}.{frac:07}Z",
        s / 3600,
        s / 60 % 60,
        s % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gmst_matches_meeus_example_12b() {
        // 1987 April 10, 19:21:00 UT: JD 2446896.30625, GMST 8h34m57.0896s.
        let unix = (2_446_896.306_25 - JD_UNIX_EPOCH) * 86_400.0;
        assert!((julian_date(unix) - 2_446_896.306_25).abs() < 1e-9);
        let want = (8.0 + 34.0 / 60.0 + 57.0896 / 3600.0) * 15.0;
        assert!((gmst_deg(2_446_896.306_25) - want).abs() < 1e-6);
        // Meeus example 12.a: 1987 April 10, 0h UT: 13h10m46.3668s.
        let want0 = (13.0 + 10.0 / 60.0 + 46.3668 / 3600.0) * 15.0;
        assert!((gmst_deg(2_446_895.5) - want0).abs() < 1e-6);
        // East longitude adds: 90° east is 6 h later in sidereal time.
        assert!((lst_deg(unix, 90.0) - (want + 90.0).rem_euclid(360.0)).abs() < 1e-6);
    }

    #[test]
    fn dates_are_written_in_iso_8601() {
        assert_eq!(iso8601(0.0), "1970-01-01T00:00:00.0000000Z");
        // 2000-02-29T12:34:56.5Z: a leap day.
        assert_eq!(iso8601(951_827_696.5), "2000-02-29T12:34:56.5000000Z");
        assert_eq!(iso8601(-1.0), "1969-12-31T23:59:59.0000000Z");
    }

    #[test]
    fn iso_8601_times_read_back_and_bad_ones_say_why() {
        for t in [0.0, 951_827_696.5, -1.0, 4_102_444_800.25, -2_208_988_800.0] {
            assert_eq!(parse_iso8601(&iso8601(t)), Ok(t), "{t}");
        }
        // Python's datetime.isoformat(), an offset, a space before Z.
        let want = 951_827_696.5;
        for text in [
            "2000-02-29T12:34:56.500000+00:00",
            "2000-02-29T14:04:56.5+01:30",
            "2000-02-29T10:34:56.5-02:00",
            "2000-02-29T12:34:56.5 Z",
        ] {
            assert_eq!(parse_iso8601(text), Ok(want), "{text}");
        }
        for (text, says) in [
            ("2000-02-29 12:34:56Z", "no T"),
            ("2000-02-29T12:34:56", "must be UTC"),
            ("2001-02-29T00:00:00Z", "out of range"),
            ("2000-13-01T00:00:00Z", "month"),
            ("1899-12-31T23:59:59Z", "year outside 1900 to 2199"),
            ("2000-01-01T24:00:00Z", "out of range"),
            ("2000-01-01T00:00Z", "HH:MM:SS"),
            ("2000-1x-01T00:00:00Z", "month"),
            ("2000-01-01T00:00:00+1:3x", "offset minutes"),
            ("", "no T"),
        ] {
            let e = parse_iso8601(text).unwrap_err();
            assert!(e.contains(says), "{text}: {e}");
        }
    }
}
