//! The arithmetic the position functions are written in.
//!
//! Every formula of a profile is written once, generic over [`Real`], and instantiated
//! twice: with `f64` on the hot path, and with [`Dd`](crate::dd::Dd) (double-double,
//! ~106-bit significand) where an edge lies so close to a half tick that `f64` cannot
//! decide which tick is nearest.

use core::ops::{Add, Div, Mul, Neg, Sub};

/// A real-number type with the functions profile shapes need.
pub trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    fn sqrt(self) -> Self;
    fn exp(self) -> Self;
    /// e^x − 1 without cancellation for small x.
    fn exp_m1(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn pi() -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        fm::sqrt(self)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        fm::exp(self)
    }
    #[inline(always)]
    fn exp_m1(self) -> Self {
        fm::exp_m1(self)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        fm::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        fm::cos(self)
    }
    #[inline(always)]
    fn pi() -> Self {
        core::f64::consts::PI
    }
}

/// f64 math: the platform's through std, or the pure-Rust `libm` crate without it.
pub mod fm {
    #[cfg(feature = "std")]
    mod imp {
        extern crate std;
        #[inline(always)]
        pub fn sqrt(x: f64) -> f64 {
            x.sqrt()
        }
        #[inline(always)]
        pub fn exp(x: f64) -> f64 {
            x.exp()
        }
        #[inline(always)]
        pub fn exp_m1(x: f64) -> f64 {
            x.exp_m1()
        }
        #[inline(always)]
        pub fn sin(x: f64) -> f64 {
            x.sin()
        }
        #[inline(always)]
        pub fn cos(x: f64) -> f64 {
            x.cos()
        }
        #[inline(always)]
        pub fn cbrt(x: f64) -> f64 {
            x.cbrt()
        }
        #[inline(always)]
        pub fn floor(x: f64) -> f64 {
            x.floor()
        }
        #[inline(always)]
        pub fn ceil(x: f64) -> f64 {
            x.ceil()
        }
    }
    #[cfg(not(feature = "std"))]
    mod imp {
        pub use libm::{cbrt, ceil, cos, exp, floor, sin, sqrt};
        #[inline(always)]
        pub fn exp_m1(x: f64) -> f64 {
            libm::expm1(x)
        }
    }
    pub use imp::*;
}
