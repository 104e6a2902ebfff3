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
}
