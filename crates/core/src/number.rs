//! Numbers as people write them in sentences, for every message of the library (a module of its
//! own so that the lowest modules, such as the model checks, can use it).

/// A number as people write it in a sentence: up to 6 significant digits without trailing
/// zeros between 1e-4 and 1e7 (`2.79584`, `90`, `1500`), otherwise scientific with up to 4
/// (`1e300`, `2.5e-9`); `inf`/`NaN` as such.
pub fn fmt_plain(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-4..1e7).contains(&a) {
        // Decimals for 6 significant digits.
        let decimals = (5 - a.log10().floor() as i32).clamp(0, 10) as usize;
        let s = format!("{v:.decimals$}");
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.')
        } else {
            &s
        };
        return s.to_string();
    }
    let s = format!("{v:.3e}");
    let (mantissa, exp) = s.split_once('e').expect("scientific format");
    let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
    format!("{mantissa}e{exp}")
}

#[cfg(test)]
mod tests {
    use super::fmt_plain;

    #[test]
    fn plain_numbers() {
        for (v, t) in [
            (2.7958366797078833, "2.79584"),
            (90.0, "90"),
            (-90.00000000001, "-90"),
            (1500.0, "1500"),
            (0.0, "0"),
            (1e300, "1e300"),
            (2.5e-9, "2.5e-9"),
            (1.23456789e7, "1.235e7"),
            (0.000123456, "0.000123456"),
            (f64::INFINITY, "inf"),
        ] {
            assert_eq!(fmt_plain(v), t, "{v}");
        }
    }
}
