//! Numbers written into a status line as `Display` writes them, without going through
//! `core::fmt` (its machinery and its float formatting were a third of a `status`
//! request). Anything the fast paths do not cover is written by `core::fmt` itself.

use std::fmt::Write;

/// `{}` of an integer.
pub(super) fn push_int(out: &mut String, x: impl itoa::Integer) {
    out.push_str(itoa::Buffer::new().format(x));
}

/// `{}` of a float: whole numbers below 2^53 as integers (`Display` writes no `.0`, and
/// `-0` for negative zero), the rest by `core::fmt`.
pub(super) fn push_float(out: &mut String, x: f64) {
    if x.fract() == 0.0 && x.abs() < 9_007_199_254_740_992.0 {
        if x.is_sign_negative() {
            out.push('-');
        }
        push_int(out, x.abs() as u64);
    } else {
        let _ = write!(out, "{x}");
    }
}

/// `{:.1}` of a float: the exact value rounded to tenths, ties to even, as `core::fmt`
/// rounds it. `x·10 = t + e` exactly (`t` the rounded product, `e` from a fused
/// multiply-add), so the one case where `t` alone misleads, `t` on a half, is settled by
/// the sign of `e` (zero: a true tie). Off a half, `t` is at least an ulp from one (below
/// 2^52 every half is a float) and `|e|` at most half an ulp, so `t` rounds as the exact
/// product does. `t − trunc(t)` is exact; `t − floor(t)` is not for negative `t`.
pub(super) fn push_tenths(out: &mut String, x: f64) {
    if x.is_nan() || x.abs() >= 1e14 {
        let _ = write!(out, "{x:.1}"); // NaN, infinities, huge values
        return;
    }
    let t = x * 10.0;
    let n = if (t - t.trunc()).abs() == 0.5 {
        // rare: the fused multiply-add is a library call without the CPU feature
        match x.mul_add(10.0, -t).partial_cmp(&0.0) {
            Some(std::cmp::Ordering::Greater) => t.ceil(),
            Some(std::cmp::Ordering::Less) => t.floor(),
            _ => t.round_ties_even(),
        }
    } else {
        t.round()
    };
    let k = n.abs() as u64;
    if x.is_sign_negative() {
        out.push('-');
    }
    push_int(out, k / 10);
    out.push('.');
    out.push((b'0' + (k % 10) as u8) as char);
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn both(x: f64) {
        let (mut a, mut b) = (String::new(), String::new());
        push_float(&mut a, x);
        push_tenths(&mut b, x);
        assert_eq!(a, format!("{x}"), "{{}} of {x:e} ({:#x})", x.to_bits());
        assert_eq!(
            b,
            format!("{x:.1}"),
            "{{:.1}} of {x:e} ({:#x})",
            x.to_bits()
        );
    }

    #[test]
    fn edge_values_read_as_display_writes_them() {
        for x in [
            0.0,
            -0.0,
            0.05,
            -0.05,
            -0.049999999999999996,
            927968401044988.5,
            1e14,
            -1e14,
            0.15,
            0.25,
            -0.25,
            0.35,
            0.45,
            2.5,
            1e15,
            -1e15,
            1e16,
            9_007_199_254_740_992.0,
            4503599627370495.5,
            0.049999999999999996,
            1e-300,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
            4000.0,
            -4000.0,
            123456.75,
            1e14 + 0.05,
        ] {
            both(x);
            both(f64::from_bits(x.to_bits().wrapping_add(1)));
            both(f64::from_bits(x.to_bits().wrapping_sub(1)));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        #[test]
        fn any_float_reads_as_display_writes_it(bits in any::<u64>()) {
            both(f64::from_bits(bits));
        }

        /// Speeds and positions as a status line shows them.
        #[test]
        fn floats_of_a_status_line_read_as_display_writes_them(x in -1e7f64..1e7) {
            both(x);
            both(x.round());
        }

        /// Near the halves, where rounding to tenths is decided.
        #[test]
        fn floats_near_a_half_tenth_read_as_display_writes_them(
            k in -1_000_000_000_000_000i64..1_000_000_000_000_000, ulps in -3i64..=3
        ) {
            let x = (k as f64 + 0.5) / 10.0;
            both(f64::from_bits((x.to_bits() as i64 + ulps) as u64));
            both((k as f64) / 4.0);
        }
    }
}
