//! One number format for everything the command prints.

/// `v` with up to `sig` significant digits: plain for magnitudes in `[1e-3, 1e6)`, scientific
/// (`1.5e-7`) otherwise, trailing zeros dropped, `0` for zero of either sign, `NaN`, `inf` and
/// `-inf` as such. A time of `9.999999999999999e-6` prints as `1e-5` at 12 digits, an energy of
/// `-7.848e18` as `-7.848e18`, never as a run of fixed-point digits.
pub(crate) fn num(v: f64, sig: usize) -> String {
    if v == 0.0 {
        return "0".to_owned();
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    let sig = sig.max(1);
    let a = v.abs();
    if (1e-3..1e6).contains(&a) {
        // Digits after the point that give `sig` significant ones.
        let exponent = a.log10().floor() as i32;
        let decimals = (sig as i32 - 1 - exponent).max(0) as usize;
        let text = format!("{v:.decimals$}");
        // Rounding may carry past 1e6 (999999.99 → 1000000): the scientific form then.
        if text.parse::<f64>().is_ok_and(|r| r.abs() < 1e6) {
            return trim_fraction(&text);
        }
    }
    let text = format!("{v:.*e}", sig - 1);
    let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
    format!("{}e{exponent}", trim_fraction(mantissa))
}

/// Drops the trailing zeros of a decimal fraction, and the point when nothing follows it.
fn trim_fraction(s: &str) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s.to_owned()
    }
}

/// `n` and the noun, singular for one: `1 body`, `3 bodies`.
pub(crate) fn count(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

#[cfg(test)]
mod tests {
    use super::{count, num};

    #[test]
    fn numbers_print_in_one_format() {
        assert_eq!(num(0.0, 10), "0");
        assert_eq!(num(-0.0, 10), "0");
        assert_eq!(num(-4.905, 10), "-4.905");
        assert_eq!(num(-4.905_721_735_255_992, 10), "-4.905721735");
        assert_eq!(num(9.999_999_999_999_999e-6, 12), "1e-5");
        assert_eq!(num(-7.848e18, 10), "-7.848e18");
        assert_eq!(num(1.5e-7, 4), "1.5e-7");
        assert_eq!(num(10.0, 12), "10");
        assert_eq!(num(999_999.999_9, 6), "1e6");
        assert_eq!(num(123_456.7, 12), "123456.7");
        assert_eq!(num(f64::NAN, 3), "NaN");
        assert_eq!(num(f64::NEG_INFINITY, 3), "-inf");
    }

    #[test]
    fn counts_agree_with_their_noun() {
        assert_eq!(count(1, "body", "bodies"), "1 body");
        assert_eq!(count(0, "body", "bodies"), "0 bodies");
        assert_eq!(count(2, "row", "rows"), "2 rows");
    }
}
