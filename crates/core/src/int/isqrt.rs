//! Integer square roots, floor(√n), with no floating point: the top half of the bits gives
//! an estimate one level down, one Newton step doubles its precision, and a correction step
//! makes it exact (Zimmermann's "Karatsuba square root" uses the same recursion).

/// floor(√n) for n < 2^32, by the bit-by-bit (restoring) method: 16 fixed iterations.
#[inline]
pub fn isqrt_u32(n: u32) -> u32 {
    let mut rem = n;
    let mut root = 0u32;
    let mut bit = 1u32 << 30;
    while bit > rem {
        bit >>= 2;
    }
    while bit != 0 {
        if rem >= root + bit {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    root
}

/// floor(√n) for u64: estimate from the top 32 bits, one Newton step, correction.
#[inline]
pub fn isqrt_u64(n: u64) -> u64 {
    if n < 1 << 32 {
        return isqrt_u32(n as u32) as u64;
    }
    // shift by an even amount so the top two bits hold the leading one
    let shift = n.leading_zeros() & !1;
    let m = n << shift;
    let hi = (m >> 32) as u32;
    let x = (isqrt_u32(hi) as u64) << 16;
    // Newton from x ≤ √m: the result is ≥ √m − 1 and within a few units above it
    let x = (x + m / x) >> 1;
    let s = correct_u64(m, x);
    s >> (shift / 2)
}

#[inline(always)]
fn correct_u64(m: u64, mut s: u64) -> u64 {
    while s.checked_mul(s).map_or(true, |sq| sq > m) {
        s -= 1;
    }
    while (s + 1).checked_mul(s + 1).is_some_and(|sq| sq <= m) {
        s += 1;
    }
    s
}

/// floor(√n) for u128: estimate from the top 64 bits, one Newton step, correction.
#[inline]
pub fn isqrt_u128(n: u128) -> u128 {
    if n < 1 << 64 {
        return isqrt_u64(n as u64) as u128;
    }
    let shift = n.leading_zeros() & !1;
    let m = n << shift;
    let hi = (m >> 64) as u64;
    let x = (isqrt_u64(hi) as u128) << 32;
    let x = (x + m / x) >> 1;
    let mut s = x;
    while s.checked_mul(s).map_or(true, |sq| sq > m) {
        s -= 1;
    }
    while (s + 1).checked_mul(s + 1).is_some_and(|sq| sq <= m) {
        s += 1;
    }
    s >> (shift / 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(n: u128) {
        let s = isqrt_u128(n);
        assert!(s * s <= n, "{n}: {s}");
        assert!(
            (s + 1).checked_mul(s + 1).map_or(true, |q| q > n),
            "{n}: {s}"
        );
    }

    #[test]
    fn edges_of_ranges() {
        for k in 0..128u32 {
            let p = 1u128 << k;
            for d in [0u128, 1, 2, 3] {
                check(p.saturating_sub(d));
                check(p.saturating_add(d));
            }
        }
        check(u128::MAX);
        check(u64::MAX as u128);
        for s in [
            1u128,
            3,
            65_535,
            65_536,
            (1 << 32) - 1,
            1 << 32,
            (1u128 << 64) - 1,
        ] {
            check(s * s);
            check(s * s - 1);
            check(s * s + 1);
        }
        assert_eq!(isqrt_u128(u128::MAX), u64::MAX as u128);
        for n in 0..100_000u32 {
            let s = isqrt_u32(n);
            assert!(s * s <= n && (s + 1) * (s + 1) > n);
        }
    }

    proptest! {
        #[test]
        fn random_u128(n in any::<u128>(), k in 0u32..128) {
            check(n >> k);
        }
        #[test]
        fn random_u64(n in any::<u64>()) {
            let s = isqrt_u64(n) as u128;
            prop_assert!(s * s <= n as u128 && (s + 1) * (s + 1) > n as u128);
        }
    }
}
