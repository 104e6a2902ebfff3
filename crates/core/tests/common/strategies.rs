//! Random moves' parameters shared by the property tests.
use multistep_core::Family;
use proptest::prelude::*;

/// Every velocity family, with its shape parameters drawn over their valid ranges.
pub fn family() -> impl Strategy<Value = Family> {
    prop_oneof![
        Just(Family::Trapezoid),
        Just(Family::Parabolic),
        (0.05f64..2.0).prop_map(|rho| Family::Exponential { rho }),
        Just(Family::Sine),
        (0.05f64..=0.5).prop_map(|phi| Family::SCurve { phi }),
        (0.05f64..=0.5, 0.05f64..=0.5).prop_map(|(phi, psi)| Family::SCurve4 { phi, psi }),
    ]
}

/// 50 MHz, or any clock from 100 kHz to 1 GHz.
pub fn clock() -> impl Strategy<Value = f64> {
    prop_oneof![Just(50e6), 1e5f64..1e9]
}
