//! Drive rates and their conversion to an axis's exact step rate.

use crate::domain::SignedRate;
use crate::error::CtlError;
use multistep_core::Rate;

/// ASCOM DriveRates, with the values its ITelescope reference gives (arcseconds of hour
/// angle per SI second): sidereal 15.041067 (one turn per sidereal day, 86164.0905 s),
/// lunar 14.685, solar 15.0 (one turn per mean solar day), King 15.0369 (King's rate
/// for refraction near the meridian).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveRate {
    Sidereal = 0,
    Lunar = 1,
    Solar = 2,
    King = 3,
}

pub const DRIVE_RATES: [DriveRate; 4] = [
    DriveRate::Sidereal,
    DriveRate::Lunar,
    DriveRate::Solar,
    DriveRate::King,
];

/// Sidereal rate, arcseconds per second.
pub const SIDEREAL: f64 = 15.041_067;
/// Seconds of right ascension to arcseconds.
pub const ARCSEC_PER_RA_SECOND: f64 = 15.0;
/// SI seconds per sidereal second (ASCOM's RightAscensionRate is per sidereal second).
pub const SI_PER_SIDEREAL_SECOND: f64 = 0.997_269_566_3;

impl DriveRate {
    pub fn from_code(n: i64) -> Option<DriveRate> {
        DRIVE_RATES.into_iter().find(|r| *r as i64 == n)
    }
    /// Micro-arcseconds per second: exact integers, so the step rate is an exact fraction.
    pub fn micro_arcsec(self) -> i64 {
        match self {
            DriveRate::Sidereal => 15_041_067,
            DriveRate::Lunar => 14_685_000,
            DriveRate::Solar => 15_000_000,
            DriveRate::King => 15_036_900,
        }
    }
}

/// Arcseconds per second as integer micro-arcseconds per second (the exact tracker's
/// input resolution here: 1e-6″/s).
pub fn micro_arcsec(arcsec_per_s: f64) -> i64 {
    (arcsec_per_s * 1e6).round() as i64
}

/// Axis angle rate `uas` (micro-arcseconds/s, signed) × `num/den` as steps/s of an axis
/// with `steps_per_rev` microsteps per turn: uas·spr·num / (1296000·1e6·den), exact.
pub fn step_rate(uas: i64, steps_per_rev: u64, num: u64, den: u64) -> Result<SignedRate, CtlError> {
    let n = uas.unsigned_abs() as u128 * steps_per_rev as u128 * num as u128;
    let d = 1_296_000_000_000u128 * den as u128;
    let rate = Rate::new(n, d).map_err(crate::tracking::track_error)?;
    Ok(SignedRate {
        negative: uas < 0 && !rate.is_zero(),
        rate,
        units: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_have_the_ascom_values() {
        let v: Vec<i64> = DRIVE_RATES.iter().map(|r| r.micro_arcsec()).collect();
        assert_eq!(v, [15_041_067, 14_685_000, 15_000_000, 15_036_900]);
        // A sidereal day of 86164.0905 s turns 360° at the sidereal rate.
        assert!((SIDEREAL * 86_164.090_5 / 1_296_000.0 - 1.0).abs() < 1e-6);
        assert_eq!(DriveRate::from_code(3), Some(DriveRate::King));
        assert_eq!(DriveRate::from_code(4), None);
    }

    #[test]
    fn step_rates_are_exact_fractions() {
        // 1296000 steps per turn: one step per arcsecond, so sidereal is 15.041067 steps/s.
        let r = step_rate(15_041_067, 1_296_000, 1, 1).unwrap();
        assert_eq!(
            (r.rate.num(), r.rate.den(), r.negative),
            (15_041_067, 1_000_000, false)
        );
        // Half the rate (a coelostat's mirror), backwards.
        let h = step_rate(-15_000_000, 1_296_000, 1, 2).unwrap();
        assert_eq!((h.rate.num(), h.rate.den(), h.negative), (15, 2, true));
        assert!(step_rate(0, 1000, 1, 1).unwrap().rate.is_zero());
        assert_eq!(micro_arcsec(-0.5), -500_000);
    }
}
