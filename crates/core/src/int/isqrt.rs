//! Integer square roots, floor(√n), with no floating point: a 192-entry seed table on
//! the top byte, Newton steps that each double the correct bits, and a correction step that
//! makes the result exact. The u128 root takes the u64 root of its top half and one more
//! Newton step (Zimmermann's "Karatsuba square root" uses the same recursion).

/// `SEED[t − 64] = ⌈√((t + 1)·2^16)⌉` for a normalised top byte t ∈ [64, 255]: shifted left
/// by 20 it is at least √m for every 64-bit m with that top byte, and at most 2^-7 above.
const SEED: [u32; 192] = seed_table();

const fn seed_table() -> [u32; 192] {
    let mut table = [0u32; 192];
    let mut i = 0;
    while i < 192 {
        let x = (i as u64 + 65) << 16;
        // ⌈√x⌉ by bisection
        let (mut lo, mut hi) = (0u64, 1u64 << 17);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if mid * mid >= x {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        table[i] = lo as u32;
        i += 1;
    }
    table
}

/// floor(√n) for n < 2^32.
#[inline]
pub fn isqrt_u32(n: u32) -> u32 {
    isqrt_u64(n as u64) as u32
}

/// floor(√n) for u64: table seed, two Newton steps from above, correction.
#[inline]
pub fn isqrt_u64(n: u64) -> u64 {
    if n == 0 {
        return 0;
    }
    // shift by an even amount so the top two bits hold the leading one
    let shift = n.leading_zeros() & !1;
    let m = n << shift;
    let mut x = (SEED[(m >> 56) as usize - 64] as u64) << 20;
    // relative error 2^-7 → 2^-15 → 2^-31: at most a few units above ⌊√m⌋ (integer Newton
    // from above never drops below it), which the correction walks down
    for _ in 0..2 {
        x = (x + m / x) >> 1;
    }
    correct_u64(m, x) >> (shift / 2)
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
