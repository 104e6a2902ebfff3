//! Hour angle and declination ↔ mechanical axis angles, and ↔ altitude and azimuth.
//!
//! Axis angles are in degrees from the home pose (both axes at count 0): the polar axis
//! with the counterweight straight down, the declination axis with the tube at the pole.
//! A German equatorial reaches each (HA, Dec) two ways, one per side of the pier:
//! pier east (looking west): p = HA − 90°, d = 90° − Dec; pier west: p = HA + 90°,
//! d = Dec − 90°. A fork has p = HA, d = Dec. A coelostat's mirror turns about the polar
//! axis only, at half the hour angle's rate (reflection doubles angles): p = HA / 2.
//! South of the equator the axes turn the other way: the northern forms apply to
//! (−HA, −Dec).

use serde::Deserialize;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Geometry {
    German,
    Fork,
    Coelostat,
}

/// ASCOM PierSide: east 0, west 1, unknown −1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PierSide {
    East = 0,
    West = 1,
    Unknown = -1,
}

/// Mechanical axis angles (degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axes {
    pub polar: f64,
    pub dec: f64,
}

/// `x` in [−180, 180).
pub fn wrap180(x: f64) -> f64 {
    (x + 180.0).rem_euclid(360.0) - 180.0
}

fn hemisphere(lat: f64) -> f64 {
    if lat < 0.0 {
        -1.0
    } else {
        1.0
    }
}

impl Geometry {
    /// The side a slew to hour angle `ha` takes: the counterweight below the polar axis
    /// (pier east for the western sky, west for the eastern).
    pub fn side_for(self, ha: f64, lat: f64) -> PierSide {
        match self {
            Geometry::German if wrap180(ha) * hemisphere(lat) >= 0.0 => PierSide::East,
            Geometry::German => PierSide::West,
            _ => PierSide::Unknown,
        }
    }

    /// The axis angles that point at (`ha`, `dec`) from `side` (a German mount's; others
    /// ignore it). `dec` of a coelostat is set by hand: its axis angle stays 0.
    pub fn to_axes(self, ha: f64, dec: f64, side: PierSide, lat: f64) -> Axes {
        let h = hemisphere(lat);
        let (ha, dec) = (wrap180(ha) * h, dec * h);
        match (self, side) {
            (Geometry::German, PierSide::West) => Axes {
                polar: wrap180(ha + 90.0),
                dec: dec - 90.0,
            },
            (Geometry::German, _) => Axes {
                polar: wrap180(ha - 90.0),
                dec: 90.0 - dec,
            },
            (Geometry::Fork, _) => Axes { polar: ha, dec },
            (Geometry::Coelostat, _) => Axes {
                polar: ha / 2.0,
                dec: 0.0,
            },
        }
    }

    /// Where axes at `a` point: (HA in [−180, 180), Dec), and the pier side.
    /// `fixed_dec` is a coelostat's declination.
    pub fn from_axes(self, a: Axes, lat: f64, fixed_dec: f64) -> (f64, f64, PierSide) {
        let h = hemisphere(lat);
        let (ha, dec, side) = match self {
            // d < 0 is the west side; the dec axis past the pole (|d| > 180) folds back.
            Geometry::German => {
                let d = wrap180(a.dec);
                if d < 0.0 {
                    (a.polar - 90.0, d + 90.0, PierSide::West)
                } else {
                    (a.polar + 90.0, 90.0 - d, PierSide::East)
                }
            }
            Geometry::Fork => (a.polar, a.dec, PierSide::Unknown),
            Geometry::Coelostat => (a.polar * 2.0, fixed_dec * h, PierSide::Unknown),
        };
        (wrap180(ha) * h, dec * h, side)
    }

    /// Axis angle per hour angle (polar) and per declination (dec axis) on `side`: the
    /// signs that turn a sky rate into axis rates.
    pub fn sense(self, side: PierSide, lat: f64) -> (f64, f64) {
        let h = hemisphere(lat);
        match (self, side) {
            (Geometry::German, PierSide::West) => (h, h),
            (Geometry::German, _) => (h, -h),
            (Geometry::Fork, _) => (h, h),
            (Geometry::Coelostat, _) => (0.5 * h, 0.0),
        }
    }

    /// ASCOM AlignmentModes: altaz 0, polar 1, German polar 2.
    pub fn alignment_mode(self) -> u8 {
        match self {
            Geometry::German => 2,
            _ => 1,
        }
    }
}

/// Altitude and azimuth (degrees, azimuth from north through east) of hour angle `ha`,
/// declination `dec` at latitude `lat` (Meeus, "Astronomical Algorithms", eq. 13.5 and
/// 13.6, with azimuth measured from north).
pub fn alt_az(ha: f64, dec: f64, lat: f64) -> (f64, f64) {
    let (h, d, p) = (ha.to_radians(), dec.to_radians(), lat.to_radians());
    let alt = (p.sin() * d.sin() + p.cos() * d.cos() * h.cos())
        .clamp(-1.0, 1.0)
        .asin();
    let az = (-d.cos() * h.sin()).atan2(d.sin() * p.cos() - d.cos() * p.sin() * h.cos());
    (alt.to_degrees(), az.to_degrees().rem_euclid(360.0))
}

/// Hour angle (degrees in [−180, 180)) and declination of altitude `alt`, azimuth `az`
/// (from north through east) at latitude `lat`: the inverse of [`alt_az`]. The horizontal
/// and equatorial frames are turned into each other by the same rotation about the east
/// point (Meeus, "Astronomical Algorithms", ch. 13), so these are eq. 13.5 and 13.6 with
/// (HA, Dec) and (Az, Alt) exchanged.
pub fn ha_dec(alt: f64, az: f64, lat: f64) -> (f64, f64) {
    let (h, a, p) = (alt.to_radians(), az.to_radians(), lat.to_radians());
    let dec = (p.sin() * h.sin() + p.cos() * h.cos() * a.cos())
        .clamp(-1.0, 1.0)
        .asin();
    let ha = (-h.cos() * a.sin()).atan2(h.sin() * p.cos() - h.cos() * p.sin() * a.cos());
    (wrap180(ha.to_degrees()), dec.to_degrees())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn axis_angles_round_trip_on_every_mount_and_side() {
        for lat in [52.0, -33.9] {
            for ha in [-179.0, -120.0, -45.5, 0.0, 0.25, 60.0, 179.5] {
                for dec in [-89.0, -30.0, 0.0, 45.0, 89.9] {
                    for (g, sides) in [
                        (Geometry::German, vec![PierSide::East, PierSide::West]),
                        (Geometry::Fork, vec![PierSide::Unknown]),
                    ] {
                        for side in sides {
                            let a = g.to_axes(ha, dec, side, lat);
                            let (h2, d2, s2) = g.from_axes(a, lat, 0.0);
                            assert!(close(wrap180(h2 - ha), 0.0), "{g:?} {side:?} {ha} {dec}");
                            assert!(close(d2, dec), "{g:?} {side:?} {ha} {dec}: {d2}");
                            if g == Geometry::German {
                                assert_eq!(s2, side);
                            }
                        }
                    }
                    let c = Geometry::Coelostat.to_axes(ha, dec, PierSide::Unknown, lat);
                    assert!(close(c.polar, ha / if lat < 0.0 { -2.0 } else { 2.0 }));
                    let (h3, d3, _) = Geometry::Coelostat.from_axes(c, lat, 12.5);
                    assert!(close(h3, ha) && close(d3, 12.5));
                }
            }
        }
    }

    #[test]
    fn the_slew_side_keeps_the_counterweight_down() {
        let g = Geometry::German;
        for ha in [-170.0, -90.0, -1.0, 0.0, 1.0, 90.0, 170.0] {
            let side = g.side_for(ha, 40.0);
            assert!(g.to_axes(ha, 20.0, side, 40.0).polar.abs() <= 90.0, "{ha}");
        }
        assert_eq!(g.side_for(30.0, 40.0), PierSide::East);
        assert_eq!(g.side_for(-30.0, 40.0), PierSide::West);
        // The home pose looks at the pole.
        let (_, dec, _) = g.from_axes(
            Axes {
                polar: 0.0,
                dec: 0.0,
            },
            40.0,
            0.0,
        );
        assert!(close(dec, 90.0));
    }

    #[test]
    fn sense_is_the_derivative_of_to_axes() {
        let lat = 47.0;
        for (g, side) in [
            (Geometry::German, PierSide::East),
            (Geometry::German, PierSide::West),
            (Geometry::Fork, PierSide::Unknown),
            (Geometry::Coelostat, PierSide::Unknown),
        ] {
            for lat in [lat, -lat] {
                let a = g.to_axes(10.0, 20.0, side, lat);
                let dh = g.to_axes(10.001, 20.0, side, lat);
                let dd = g.to_axes(10.0, 20.001, side, lat);
                let (sp, sd) = g.sense(side, lat);
                assert!(((dh.polar - a.polar) / 0.001 - sp).abs() < 1e-6);
                assert!(((dd.dec - a.dec) / 0.001 - sd).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn altitude_and_azimuth_have_their_closed_forms() {
        // On the meridian an object culminates at 90° − |lat − dec|, due south (north of
        // the equator, south of the zenith).
        let (alt, az) = alt_az(0.0, 20.0, 50.0);
        assert!(close(alt, 60.0) && close(az, 180.0));
        // The pole stands at the latitude's altitude, due north.
        let (alt, az) = alt_az(37.0, 90.0, 50.0);
        assert!(close(alt, 50.0) && (close(az, 0.0) || close(az, 360.0)));
        // The celestial equator rises due east at HA −90°.
        let (alt, az) = alt_az(-90.0, 0.0, 50.0);
        assert!(close(alt, 0.0) && close(az, 90.0));
    }

    #[test]
    fn hour_angle_and_declination_invert_altitude_and_azimuth() {
        for lat in [52.0, -33.9, 0.0] {
            for ha in [-179.0, -120.0, -45.5, 0.0, 0.25, 60.0, 179.5] {
                for dec in [-80.0, -30.0, 0.0, 45.0, 89.0] {
                    let (alt, az) = alt_az(ha, dec, lat);
                    let (h2, d2) = ha_dec(alt, az, lat);
                    assert!(close(wrap180(h2 - ha), 0.0), "{lat} {ha} {dec}: {h2}");
                    assert!(close(d2, dec), "{lat} {ha} {dec}: {d2}");
                }
            }
        }
        // Due south at the co-latitude is the celestial equator on the meridian; the
        // zenith is the latitude's declination.
        let (ha, dec) = ha_dec(40.0, 180.0, 50.0);
        assert!(close(ha, 0.0) && close(dec, 0.0));
        let (ha, dec) = ha_dec(90.0, 0.0, 50.0);
        assert!(close(ha, 0.0) && close(dec, 50.0));
    }
}
