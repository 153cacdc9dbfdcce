//! Time stamps as written, subtracted exactly: an epoch stamp in µs (1.7e15) or ns (1.7e18)
//! converted to f64 seconds first would lose its last digits (f64 seconds near 1.7e9 step by
//! 0.24 µs, ns stamps do not fit f64's 53 bits at all), so the first stamp is subtracted in
//! integers and only the difference becomes f64.

/// A time stamp as written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Stamp {
    /// A plain decimal of at most 30 digits: `mantissa · 10^-decimals`, exact.
    Exact {
        /// The digits, signed.
        mantissa: i128,
        /// Digits after the decimal point.
        decimals: u32,
    },
    /// Anything else that reads as a number (exponents, more digits): the nearest f64.
    Float(f64),
}

/// Digits kept exact: ns epoch stamps (19 digits) with room for decimals.
const EXACT_DIGITS: usize = 30;

impl Stamp {
    /// The stamp `text` writes (a `.` decimal point); `None` when it is not a finite number.
    pub(super) fn parse(text: &str) -> Option<Stamp> {
        let digits = text.strip_prefix(['-', '+']).unwrap_or(text);
        let (int, frac) = digits.split_once('.').unwrap_or((digits, ""));
        let plain = !(int.is_empty() && frac.is_empty())
            && int.bytes().chain(frac.bytes()).all(|b| b.is_ascii_digit())
            && int.len() + frac.len() <= EXACT_DIGITS;
        if plain {
            let all: String = int.chars().chain(frac.chars()).collect();
            let m: i128 = if all.is_empty() { 0 } else { all.parse().ok()? };
            let mantissa = if text.starts_with('-') { -m } else { m };
            // Length checked above: at most 30.
            let decimals = u32::try_from(frac.len()).ok()?;
            return Some(Stamp::Exact { mantissa, decimals });
        }
        text.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .map(Stamp::Float)
    }

    /// The nearest f64.
    fn to_f64(self) -> f64 {
        match self {
            Stamp::Exact { mantissa, decimals } => mantissa as f64 / 10f64.powi(decimals as i32),
            Stamp::Float(v) => v,
        }
    }

    /// `self − origin`, exact before the one rounding to f64 when both are exact.
    pub(super) fn minus(self, origin: Stamp) -> f64 {
        match (self, origin) {
            (
                Stamp::Exact {
                    mantissa: a,
                    decimals: da,
                },
                Stamp::Exact {
                    mantissa: b,
                    decimals: db,
                },
            ) => {
                let d = da.max(db);
                let scaled = |m: i128, dm: u32| 10i128.checked_pow(d - dm)?.checked_mul(m);
                match (scaled(a, da), scaled(b, db)) {
                    // 10^d for d ≤ 22 is exact in f64, so the quotient is correctly rounded.
                    (Some(a), Some(b)) if d <= 22 => match a.checked_sub(b) {
                        Some(diff) => diff as f64 / 10f64.powi(d as i32),
                        None => self.to_f64() - origin.to_f64(),
                    },
                    _ => self.to_f64() - origin.to_f64(),
                }
            }
            _ => self.to_f64() - origin.to_f64(),
        }
    }

    /// Whether the stamp is zero (no origin to subtract).
    pub(super) fn is_zero(self) -> bool {
        self.to_f64() == 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// µs and ns epoch stamps one unit apart stay one unit apart; through f64 they would not
    /// (1 712 345 678 901 234 567 ns is not an f64).
    #[test]
    fn epoch_stamps_keep_their_last_digit() {
        let us0 = Stamp::parse("1712345678901234").unwrap();
        let us1 = Stamp::parse("1712345678901235").unwrap();
        assert_eq!(us1.minus(us0), 1.0);
        let ns0 = Stamp::parse("1712345678901234567").unwrap();
        let ns1 = Stamp::parse("1712345678901234568").unwrap();
        assert_eq!(ns1.minus(ns0), 1.0);
        assert_ne!(
            1_712_345_678_901_234_568f64 - 1_712_345_678_901_234_567f64,
            1.0,
            "the f64 path this guards against"
        );
        let s0 = Stamp::parse("1712345678.123456").unwrap();
        let s1 = Stamp::parse("1712345678.623457").unwrap();
        assert_eq!(s1.minus(s0), 0.500001);
        assert_eq!(
            Stamp::parse("-1.5")
                .unwrap()
                .minus(Stamp::parse("2").unwrap()),
            -3.5
        );
    }

    #[test]
    fn other_numbers_fall_back_to_f64_and_text_is_refused() {
        assert_eq!(Stamp::parse("1e3"), Some(Stamp::Float(1000.0)));
        let long = "1234567890123456789012345678901234567890";
        assert_eq!(
            Stamp::parse(long),
            Some(Stamp::Float(1.234_567_890_123_456_8e39))
        );
        for bad in ["", ".", "-", "abc", "NaN", "inf", "1.2.3"] {
            assert_eq!(Stamp::parse(bad), None, "{bad}");
        }
        assert!(Stamp::parse("0.000").unwrap().is_zero());
    }
}
