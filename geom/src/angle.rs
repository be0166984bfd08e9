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

/// How much longer the arc of a steady turn through `turn_rad` (a signed turn in
/// `[-pi, pi]`, e.g. from [`wrap_pi`]) is than its chord: `(x/2) / sin(x/2)`, 1 for no
/// turn. A ground speed read from two positions' chord is this much short in a turn.
pub fn arc_over_chord(turn_rad: f64) -> f64 {
    let half = 0.5 * turn_rad.abs();
    if half < 1e-9 { 1.0 } else { half / half.sin() }
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
