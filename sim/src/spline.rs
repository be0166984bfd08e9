//! Closed-loop obstacle tours as the judges' interop server flew them (2017/2018).
//!
//! Each of x, y and altitude is a periodic interpolating spline against time through the
//! waypoint loop `w0, w1, ..., w(n-1), w0`: cubic for three or more waypoints, quadratic for
//! two (the server's `splrep(k = 3 if enough points else 2, per = 1)`; with an even degree
//! FITPACK puts the knots half-way between the data points). Knot times are the cumulative
//! 3-D leg length divided by the average speed; the position at time `t` is the spline at
//! `t mod period`. The speed therefore varies around the average and the altitude overshoots
//! the waypoints, as the judges' obstacles did.
//!
//! # Units
//! ENU metres, metres MSL, seconds, m/s.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why a tour cannot be built.
#[derive(Debug, Error, PartialEq)]
#[non_exhaustive]
pub enum TourError {
    /// Fewer than two waypoints: give at least two (one waypoint is a stationary sphere).
    #[error("a tour needs at least two waypoints, got {0}")]
    TooFewWaypoints(usize),
    /// Non-positive or non-finite average speed: give a speed above zero.
    #[error("average speed must be positive, got {0}")]
    BadSpeed(f64),
    /// Two consecutive waypoints coincide, which makes a zero-length knot interval.
    #[error("consecutive waypoints {0} and {1} coincide")]
    RepeatedWaypoint(usize, usize),
}

/// A periodic spline tour through waypoints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SplineTour {
    /// The loop's waypoints (not repeated at the end).
    pub waypoints_m: Vec<[f64; 3]>,
    /// Knot times: `knots_s[i]` is when the tour passes waypoint `i`; `knots_s[n]` = period.
    pub knots_s: Vec<f64>,
    /// Second derivatives at the knots, per axis (cubic case only).
    second_derivs: Vec<[f64; 3]>,
}

impl SplineTour {
    /// Builds the tour through `waypoints_m` at `speed_avg_mps`.
    ///
    /// # Errors
    /// [`TourError`] when fewer than two waypoints, a non-positive speed, or a zero-length leg.
    pub fn new(waypoints_m: Vec<[f64; 3]>, speed_avg_mps: f64) -> Result<Self, TourError> {
        let n = waypoints_m.len();
        if n < 2 {
            return Err(TourError::TooFewWaypoints(n));
        }
        if !(speed_avg_mps.is_finite() && speed_avg_mps > 0.0) {
            return Err(TourError::BadSpeed(speed_avg_mps));
        }
        let mut knots_s = vec![0.0];
        for i in 0..n {
            let (a, b) = (waypoints_m[i], waypoints_m[(i + 1) % n]);
            let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
            if d <= 1e-9 {
                return Err(TourError::RepeatedWaypoint(i, (i + 1) % n));
            }
            knots_s.push(knots_s[i] + d / speed_avg_mps);
        }
        let second_derivs = if n >= 3 {
            periodic_cubic_second_derivs(&waypoints_m, &knots_s)
        } else {
            vec![]
        };
        Ok(Self {
            waypoints_m,
            knots_s,
            second_derivs,
        })
    }

    /// The loop's period, seconds.
    pub fn period_s(&self) -> f64 {
        *self.knots_s.last().unwrap()
    }

    /// Position at time `t_s` (any real; the phase is `t_s mod period`).
    pub fn position(&self, t_s: f64) -> [f64; 3] {
        let period = self.period_s();
        let t = t_s.rem_euclid(period);
        let n = self.waypoints_m.len();
        if n == 2 {
            return self.quadratic(t);
        }
        // interval i with knots[i] <= t < knots[i+1]
        let i = match self.knots_s.partition_point(|&k| k <= t) {
            0 => 0,
            k => (k - 1).min(n - 1),
        };
        let (t0, t1) = (self.knots_s[i], self.knots_s[i + 1]);
        let h = t1 - t0;
        let (a, b) = (t1 - t, t - t0);
        let (y0, y1) = (self.waypoints_m[i], self.waypoints_m[(i + 1) % n]);
        let (m0, m1) = (self.second_derivs[i], self.second_derivs[(i + 1) % n]);
        let mut out = [0.0; 3];
        for k in 0..3 {
            out[k] = m0[k] * a * a * a / (6.0 * h)
                + m1[k] * b * b * b / (6.0 * h)
                + (y0[k] / h - m0[k] * h / 6.0) * a
                + (y1[k] / h - m1[k] * h / 6.0) * b;
        }
        out
    }

    /// Two waypoints: knots half-way between the data, so each piece is a parabola with its
    /// vertex at a waypoint: `y = w0 + 2 (w1 - w0) t^2 / h^2` for `|t| <= h/2`, where `h` is
    /// half the period, and symmetrically around `w1`. Continuous in value and slope.
    fn quadratic(&self, t: f64) -> [f64; 3] {
        let h = self.knots_s[1];
        let period = self.period_s();
        let (w0, w1) = (self.waypoints_m[0], self.waypoints_m[1]);
        // distance in time to the nearest vertex, and which vertex it is
        let (base, other, s) = if t <= h / 2.0 {
            (w0, w1, t)
        } else if t <= h + (period - h) / 2.0 {
            (w1, w0, t - h)
        } else {
            (w0, w1, t - period)
        };
        // half-period on the side we are on (equal to h when legs are symmetric, which they are:
        // both legs are the same segment)
        let mut out = [0.0; 3];
        for k in 0..3 {
            out[k] = base[k] + 2.0 * (other[k] - base[k]) * s * s / (h * h);
        }
        out
    }
}

/// Second derivatives `M_i` of the periodic cubic spline through `y` at `knots`
/// (`knots.len() == y.len() + 1`), solving the cyclic system
/// `h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i M_{i+1} = 6 ((y_{i+1}-y_i)/h_i - (y_i-y_{i-1})/h_{i-1})`.
fn periodic_cubic_second_derivs(y: &[[f64; 3]], knots: &[f64]) -> Vec<[f64; 3]> {
    let n = y.len();
    let h: Vec<f64> = (0..n).map(|i| knots[i + 1] - knots[i]).collect();
    let mut out = vec![[0.0; 3]; n];
    for k in 0..3 {
        let mut a = vec![vec![0.0; n]; n];
        let mut rhs = vec![0.0; n];
        for i in 0..n {
            let im = (i + n - 1) % n;
            let ip = (i + 1) % n;
            a[i][im] += h[im];
            a[i][i] += 2.0 * (h[im] + h[i]);
            a[i][ip] += h[i];
            rhs[i] = 6.0 * ((y[ip][k] - y[i][k]) / h[i] - (y[i][k] - y[im][k]) / h[im]);
        }
        let m = solve_dense(a, rhs);
        for i in 0..n {
            out[i][k] = m[i];
        }
    }
    out
}

/// Gaussian elimination with partial pivoting for a small, diagonally dominant system.
fn solve_dense(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for col in 0..n {
        let piv = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap();
        a.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            if f != 0.0 {
                for c in col..n {
                    a[row][c] -= f * a[col][c];
                }
                b[row] -= f * b[col];
            }
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|c| a[row][c] * x[c]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    fn square() -> SplineTour {
        // 4 waypoints on a 400 m square, altitudes varying; 3-D legs: 400, ~400.5, 400, ~400.5
        SplineTour::new(
            vec![
                [0.0, 0.0, 100.0],
                [400.0, 0.0, 100.0],
                [400.0, 400.0, 120.0],
                [0.0, 400.0, 100.0],
            ],
            10.0,
        )
        .unwrap()
    }

    #[test]
    fn the_tour_passes_through_each_waypoint_at_its_knot_time() {
        let s = square();
        // first leg 400 m at 10 m/s: knot 1 at 40 s
        assert_abs_diff_eq!(s.knots_s[1], 40.0, epsilon = 1e-12);
        for (i, w) in s.waypoints_m.iter().enumerate() {
            let p = s.position(s.knots_s[i]);
            for k in 0..3 {
                assert_abs_diff_eq!(p[k], w[k], epsilon = 1e-9);
            }
        }
    }

    #[test]
    fn the_tour_is_periodic_and_smooth_across_the_wrap() {
        let s = square();
        let per = s.period_s();
        for t in [0.0, 3.3, 41.0, 97.5, 150.0] {
            let (a, b) = (s.position(t), s.position(t + per));
            let c = s.position(t - 3.0 * per);
            for k in 0..3 {
                assert_abs_diff_eq!(a[k], b[k], epsilon = 1e-9);
                assert_abs_diff_eq!(a[k], c[k], epsilon = 1e-9);
            }
        }
        // slope continuity at the wrap: finite differences either side of t = 0 agree
        let e = 1e-4;
        let before = s.position(per - e);
        let at = s.position(0.0);
        let after = s.position(e);
        for k in 0..3 {
            let (d0, d1) = ((at[k] - before[k]) / e, (after[k] - at[k]) / e);
            assert_abs_diff_eq!(d0, d1, epsilon = 1e-2);
        }
    }

    #[test]
    fn the_average_speed_over_a_period_is_close_to_the_requested_one() {
        let s = square();
        let steps = 20_000;
        let dt = s.period_s() / f64::from(steps);
        let mut len = 0.0;
        let mut prev = s.position(0.0);
        for i in 1..=steps {
            let p = s.position(f64::from(i) * dt);
            len += ((p[0] - prev[0]).powi(2) + (p[1] - prev[1]).powi(2) + (p[2] - prev[2]).powi(2))
                .sqrt();
            prev = p;
        }
        let avg = len / s.period_s();
        // the spline bulges outside the square, so it is a bit faster than 10 m/s; within 20%
        assert!((avg - 10.0).abs() < 2.0, "avg speed {avg}");
    }

    #[test]
    fn two_waypoints_make_a_quadratic_shuttle_stopping_at_each_end() {
        // 200 m apart at 10 m/s: knots 0, 20, 40 s. Midway (t = 10 s) the obstacle is half-way,
        // at t = 5 s it has covered 2 * 200 * 25 / 400 = 25 m.
        let s = SplineTour::new(vec![[0.0, 0.0, 50.0], [200.0, 0.0, 50.0]], 10.0).unwrap();
        assert_abs_diff_eq!(s.period_s(), 40.0, epsilon = 1e-12);
        assert_abs_diff_eq!(s.position(0.0)[0], 0.0, epsilon = 1e-9);
        assert_abs_diff_eq!(s.position(5.0)[0], 25.0, epsilon = 1e-9);
        assert_abs_diff_eq!(s.position(10.0)[0], 100.0, epsilon = 1e-9);
        assert_abs_diff_eq!(s.position(20.0)[0], 200.0, epsilon = 1e-9);
        assert_abs_diff_eq!(s.position(35.0)[0], 25.0, epsilon = 1e-9);
        assert_abs_diff_eq!(s.position(45.0)[0], 25.0, epsilon = 1e-9);
    }

    #[test]
    fn bad_tours_are_refused() {
        assert_eq!(
            SplineTour::new(vec![[0.0; 3]], 5.0),
            Err(TourError::TooFewWaypoints(1))
        );
        assert_eq!(
            SplineTour::new(vec![[0.0; 3], [1.0, 0.0, 0.0]], 0.0),
            Err(TourError::BadSpeed(0.0))
        );
        assert!(matches!(
            SplineTour::new(vec![[0.0; 3], [0.0; 3], [1.0, 0.0, 0.0]], 5.0),
            Err(TourError::RepeatedWaypoint(0, 1))
        ));
    }
}
