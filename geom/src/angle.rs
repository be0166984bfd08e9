//!
//! The predictor's heading and turn-rate estimates and the simulator's aircraft model both
//! need a heading difference as a signed turn.

use std::f64::consts::{PI, TAU};

/// Wraps an angle in radians to `(-pi, pi]`.
pub fn wrap_pi(a_rad: f64) -> f64 {
    let mut a = a_rad % TAU;
    if a > PI {
        a -= TAU;
    } else if a <= -PI {
        a += TAU;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_half_turn_either_way_is_plus_pi() {
        assert_eq!(wrap_pi(PI), PI);
        assert_eq!(wrap_pi(-PI), PI);
        assert_eq!(wrap_pi(3.0 * PI), PI);
        assert!((wrap_pi(1.5 * PI) + 0.5 * PI).abs() < 1e-12);
    }
}
