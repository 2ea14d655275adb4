//! Value parsers that bound every count and number at parse time, before
//! anything is read or allocated. A bound says why in its error; the
//! numbers are chosen in the flags' definitions, with the reason there.

/// A whole number in `lo..=hi`.
pub fn count(s: &str, lo: usize, hi: usize) -> Result<usize, String> {
    let v: usize = s.trim().parse().map_err(|_| format!("'{s}' is not a whole number in {lo}..={hi}"))?;
    if !(lo..=hi).contains(&v) {
        return Err(format!("{v} is outside {lo}..={hi}"));
    }
    Ok(v)
}

/// A finite number in `lo..=hi`.
pub fn number(s: &str, lo: f32, hi: f32) -> Result<f32, String> {
    let v: f32 = s.trim().parse().map_err(|_| format!("'{s}' is not a number"))?;
    if !v.is_finite() {
        return Err(format!("{s} is not a finite number"));
    }
    if !(lo..=hi).contains(&v) {
        return Err(format!("{v} is outside {lo}..={hi}"));
    }
    Ok(v)
}

/// A finite number above `lo` (exclusive) and at most `hi`.
pub fn positive(s: &str, lo: f32, hi: f32) -> Result<f32, String> {
    let v = number(s, lo, hi)?;
    if v <= lo {
        return Err(format!("{v} must be greater than {lo}"));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_refuse_what_is_outside_and_every_non_finite_value() {
        assert_eq!(count("12", 1, 12), Ok(12));
        assert!(count("13", 1, 12).is_err() && count("0", 1, 12).is_err() && count("18446744073709551616", 1, 12).is_err());
        assert_eq!(number("0.5", 0.0, 1.0), Ok(0.5));
        for bad in ["nan", "inf", "-inf", "NaN", "1.5", "-0.1", "x"] {
            assert!(number(bad, 0.0, 1.0).is_err(), "{bad}");
        }
        assert!(positive("0", 0.0, 1.0).is_err() && positive("1e-3", 0.0, 1.0).is_ok());
    }
}
