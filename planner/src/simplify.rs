//! Risk-aware polyline simplification (DESIGN.md "Planner", step 5: "simplify to few
//! waypoints").
//!
//! The bisection's bottom level returns densely sampled paths. Greedily, from each kept
//! point the farthest later point is taken whose shortcut is no worse than the stretch it
//! replaces: no hard violation (cylinder buffer or fly zone) unless the stretch had one
//! too, no higher peak risk and no more exposure (evaluated on the same clock, every
//! `step_m`). The scan from a point stops after a few consecutive rejected shortcuts, so
//! the cost is linear in the number of points for typical paths.

use crate::cost::LegEnv;
use crate::geometry::{Point, dist};

/// Consecutive rejected shortcuts before the scan from one point stops.
const PATIENCE: usize = 4;

/// A shortcut may raise the peak risk by this much (risk well below any safety
/// threshold is noise for the aircraft, and keeping a waypoint for it costs a turn).
pub const PEAK_SLACK: f64 = 0.01;
/// A shortcut may raise the exposure by this much, metres at risk 1.
pub const EXPOSURE_SLACK_M: f64 = 0.5;

/// Simplifies `points` (first and last kept) flown from `t0_s`.
pub fn simplify_path(env: &LegEnv<'_>, points: &[Point], t0_s: f64, step_m: f64) -> Vec<Point> {
    let n = points.len();
    if n <= 2 {
        return points.to_vec();
    }
    // Per-segment summaries of the original path on its own clock.
    let mut t_at = vec![t0_s; n];
    let mut seg_exp = vec![0.0; n - 1];
    let mut seg_peak = vec![0.0f64; n - 1];
    let mut seg_hard = vec![false; n - 1];
    for i in 0..n - 1 {
        let r = env.path_risk(&points[i..=i + 1], t_at[i], step_m);
        seg_exp[i] = r.exposure_m;
        seg_peak[i] = r.peak;
        seg_hard[i] = env.segment_hard(points[i], points[i + 1], env.buffer_fraction);
        t_at[i + 1] = t_at[i] + dist(points[i], points[i + 1]) / env.speed_mps;
    }
    let mut out = vec![points[0]];
    let mut i = 0;
    while i < n - 1 {
        let mut best = i + 1;
        let (mut exp, mut peak, mut hard) = (seg_exp[i], seg_peak[i], seg_hard[i]);
        let mut misses = 0;
        for j in i + 2..n {
            exp += seg_exp[j - 1];
            peak = peak.max(seg_peak[j - 1]);
            hard |= seg_hard[j - 1];
            let short_hard = env.segment_hard(points[i], points[j], env.buffer_fraction);
            let ok = if short_hard && !hard {
                false
            } else {
                let r = env.path_risk(&[points[i], points[j]], t_at[i], step_m);
                r.peak <= peak + PEAK_SLACK && r.exposure_m <= exp + EXPOSURE_SLACK_M
            };
            if ok {
                best = j;
                misses = 0;
            } else {
                misses += 1;
                if misses >= PATIENCE {
                    break;
                }
            }
        }
        out.push(points[best]);
        i = best;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::{Cylinder, Zones};

    #[test]
    fn wiggles_in_free_space_collapse_to_a_line() {
        let zones = Zones::default();
        let env = LegEnv {
            risk: &predictor::field::NoRisk,
            zones: &zones,
            cylinders: &[],
            alt_m: 50.0,
            band_m: crate::cost::ALL_ALTITUDES,
            band_hint: predictor::NO_BAND_HINT,
            buffer_fraction: 0.2,
            speed_mps: 20.0,
            horizon_end_s: 1e9,
        };
        let pts: Vec<Point> = (0..=20)
            .map(|i| [i as f64 * 10.0, if i % 2 == 0 { 0.0 } else { 1.0 }])
            .collect();
        let s = simplify_path(&env, &pts, 0.0, 5.0);
        assert_eq!(s, vec![[0.0, 0.0], [200.0, 0.0]]);
    }

    #[test]
    fn a_detour_round_a_cylinder_is_kept() {
        // Cylinder r = 20 at (100, 0); the path goes over the top via (100, 40).
        let zones = Zones::default();
        let cyl = [Cylinder {
            center_m: [100.0, 0.0],
            radius_m: 20.0,
            top_m: 100.0,
        }];
        let env = LegEnv {
            risk: &predictor::field::NoRisk,
            zones: &zones,
            cylinders: &cyl,
            alt_m: 50.0,
            band_m: crate::cost::ALL_ALTITUDES,
            band_hint: predictor::NO_BAND_HINT,
            buffer_fraction: 0.2,
            speed_mps: 20.0,
            horizon_end_s: 1e9,
        };
        let pts = vec![
            [0.0, 0.0],
            [50.0, 30.0],
            [100.0, 40.0],
            [150.0, 30.0],
            [200.0, 0.0],
        ];
        let s = simplify_path(&env, &pts, 0.0, 5.0);
        assert!(s.len() >= 3);
        for w in s.windows(2) {
            assert!(!env.segment_hard(w[0], w[1], 0.2));
        }
    }
}
