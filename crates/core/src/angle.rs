//! Angles: wrapping and degree/radian conversion.
//!
//! Headings on the wire are in [0, 2 pi) clockwise from north; errors and differences are
//! wrapped to [-pi, pi). Rudder angles are never wrapped.

use std::f64::consts::PI;

/// Radians per degree.
pub const DEG: f64 = PI / 180.0;

/// Degrees to radians.
pub fn deg(x_deg: f64) -> f64 {
    x_deg * DEG
}

/// Radians to degrees.
pub fn to_deg(x_rad: f64) -> f64 {
    x_rad / DEG
}

/// Wraps an angle to [0, 2 pi).
pub fn wrap_2pi(x_rad: f64) -> f64 {
    let y = x_rad.rem_euclid(2.0 * PI);
    // rem_euclid can return exactly 2 pi for tiny negative inputs.
    if y >= 2.0 * PI {
        0.0
    } else {
        y
    }
}

/// Wraps an angle to [-pi, pi).
pub fn wrap_pi(x_rad: f64) -> f64 {
    wrap_2pi(x_rad + PI) - PI
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps() {
        assert!((wrap_2pi(-0.1) - (2.0 * PI - 0.1)).abs() < 1e-12);
        assert!((wrap_2pi(7.0) - (7.0 - 2.0 * PI)).abs() < 1e-12);
        assert_eq!(wrap_2pi(-1e-20), 0.0);
        assert!((wrap_pi(3.5) - (3.5 - 2.0 * PI)).abs() < 1e-12);
        assert!((wrap_pi(-3.5) - (-3.5 + 2.0 * PI)).abs() < 1e-12);
        assert!((wrap_pi(0.3) - 0.3).abs() < 1e-15);
        assert!((to_deg(deg(12.5)) - 12.5).abs() < 1e-12);
    }
}
