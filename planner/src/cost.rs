//! Path scoring shared by the bisection search, the simplifier and the plan's final
//! check (DESIGN.md "Planner", step 3): risk along a timed path, hard violations
//! (cylinders, fly zone) and length.
//!
//! A path is flown at constant speed from a start time; each evaluated point is stamped
//! with its arrival time. Dynamic risk counts only up to the horizon end (beyond it the
//! prediction is not trusted and the next replan takes over).
//!
//! # Units
//! Metres, seconds; exposure is "metres flown at risk 1" (the integral of risk over path
//! length).

use predictor::RiskField;

use crate::geometry::{Point, dist, dist_point_segment, lerp};
use crate::mission::{Cylinder, Zones};

/// What a leg is scored against.
#[derive(Clone, Copy)]
pub struct LegEnv<'a> {
    /// The risk field (moving obstacles).
    pub risk: &'a dyn RiskField,
    /// Fly zones.
    pub zones: &'a Zones,
    /// All cylinders; filtered by `alt_m`.
    pub cylinders: &'a [Cylinder],
    /// The leg's altitude, metres MSL.
    pub alt_m: f64,
    /// Safety buffer fraction for the cylinders.
    pub buffer_fraction: f64,
    /// Ground speed, m/s.
    pub speed_mps: f64,
    /// Dynamic risk is ignored after this time, seconds.
    pub horizon_end_s: f64,
}

impl std::fmt::Debug for LegEnv<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LegEnv")
            .field("alt_m", &self.alt_m)
            .field("speed_mps", &self.speed_mps)
            .field("horizon_end_s", &self.horizon_end_s)
            .finish_non_exhaustive()
    }
}

/// The risk summary of a timed polyline.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PathRisk {
    /// Highest risk at any evaluated point (1 when a hard violation occurs).
    pub peak: f64,
    /// Integral of risk over path length, metres.
    pub exposure_m: f64,
    /// Segments entering a cylinder (its radius, no buffer) or leaving the fly zone.
    pub hard_violations: usize,
    /// Length, metres.
    pub length_m: f64,
    /// Arrival time at the last point, seconds.
    pub end_t_s: f64,
}

impl LegEnv<'_> {
    /// Whether segment `a -> b` enters a cylinder grown by `grow` of its radius, or leaves
    /// the fly zone.
    pub fn segment_hard(&self, a: Point, b: Point, grow: f64) -> bool {
        self.cylinders.iter().any(|c| {
            c.matters_at(self.alt_m)
                && dist_point_segment(c.center_m, a, b) < c.radius_m * (1.0 + grow) - 1e-9
        }) || !self.zones.contains_segment(a, b)
    }

    /// Risk summary of `points` flown from `t0_s`, evaluated every `step_m` metres.
    pub fn path_risk(&self, points: &[Point], t0_s: f64, step_m: f64) -> PathRisk {
        let mut out = PathRisk {
            end_t_s: t0_s,
            ..PathRisk::default()
        };
        let mut t = t0_s;
        for w in points.windows(2) {
            let (a, b) = (w[0], w[1]);
            let l = dist(a, b);
            if self.segment_hard(a, b, 0.0) {
                out.hard_violations += 1;
                out.peak = 1.0;
            }
            if t <= self.horizon_end_s && l > 0.0 {
                let n = (l / step_m).ceil().max(1.0) as usize;
                let ds = l / n as f64;
                for i in 1..=n {
                    let ti = t + (i as f64 * ds) / self.speed_mps;
                    if ti > self.horizon_end_s {
                        break;
                    }
                    let r = self.risk.risk(lerp(a, b, i as f64 / n as f64), ti);
                    out.peak = out.peak.max(r);
                    out.exposure_m += r * ds;
                }
            }
            t += l / self.speed_mps;
            out.length_m += l;
        }
        out.end_t_s = t;
        out
    }
}

/// Orders two summaries: fewer hard violations, then lower peak, then lower exposure,
/// then shorter. Returns true when `a` is strictly better than `b`.
pub fn better(a: &PathRisk, b: &PathRisk) -> bool {
    if a.hard_violations != b.hard_violations {
        return a.hard_violations < b.hard_violations;
    }
    if (a.peak - b.peak).abs() > 1e-9 {
        return a.peak < b.peak;
    }
    if (a.exposure_m - b.exposure_m).abs() > 1e-9 {
        return a.exposure_m < b.exposure_m;
    }
    a.length_m < b.length_m - 1e-9
}
