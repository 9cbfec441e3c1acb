//! Planar angles.

use std::f64::consts::PI;

/// An angle wrapped into (-pi, pi].
///
/// # Examples
/// ```
/// use std::f64::consts::PI;
/// use rperc_core::wrap_angle;
///
/// assert_eq!(wrap_angle(3.0 * PI), PI);
/// assert_eq!(wrap_angle(-PI), PI);
/// assert!((wrap_angle(7.0) - (7.0 - 2.0 * PI)).abs() < 1e-15);
/// ```
pub fn wrap_angle(a: f64) -> f64 {
    // Most angles (innovations, headings) are in range already: returned as they
    // are, exactly (the remainder below would round a negative one by an ulp), and
    // without a floating-point remainder, which is slow.
    if a > -PI && a <= PI {
        return a;
    }
    let w = a.rem_euclid(2.0 * PI);
    if w > PI { w - 2.0 * PI } else { w }
}

/// The signed difference `a - b`, wrapped into (-pi, pi]: how far to turn from `b` to `a`.
pub fn angle_diff(a: f64, b: f64) -> f64 {
    wrap_angle(a - b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_into_half_open_interval() {
        for k in -50..=50 {
            let a = k as f64 * 0.37;
            let w = wrap_angle(a);
            assert!(w > -PI && w <= PI, "{a} -> {w}");
            // Same angle: the difference is a multiple of 2 pi.
            let turns = (a - w) / (2.0 * PI);
            assert!((turns - turns.round()).abs() < 1e-12);
        }
        assert_eq!(angle_diff(-3.0, 3.0), wrap_angle(-6.0));
    }

    /// An angle already in (-pi, pi] comes back unchanged, bit for bit; the ends
    /// and NaN follow the general rule.
    #[test]
    fn an_angle_in_range_is_unchanged() {
        for a in [-3.1, -1.0, -1e-300, -0.0, 0.0, 0.3, 2.9, PI] {
            assert_eq!(wrap_angle(a).to_bits(), a.to_bits(), "{a}");
        }
        assert_eq!(wrap_angle(-PI), PI);
        assert!(wrap_angle(f64::NAN).is_nan());
    }
}
