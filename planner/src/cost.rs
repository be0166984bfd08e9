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
    /// The leg's altitude for cylinders, metres MSL (the lower of its ends').
    pub alt_m: f64,
    /// The altitudes the aircraft may fly this leg at, `[lowest, highest]` metres MSL
    /// ([`leg_bands`]): a sphere out of their reach is passed over or under
    /// ([`RiskField::risk_in_band`]). [`ALL_ALTITUDES`] counts every obstacle.
    pub band_m: [f64; 2],
    /// The risk field's summary of `band_m` ([`RiskField::band_hint`]), set by
    /// [`LegEnv::in_band`]; [`predictor::NO_BAND_HINT`] works it out on every read.
    pub band_hint: u64,
    /// Safety buffer fraction for the cylinders.
    pub buffer_fraction: f64,
    /// Ground speed, m/s.
    pub speed_mps: f64,
    /// Dynamic risk is ignored after this time, seconds.
    pub horizon_end_s: f64,
}

/// A band that every obstacle reaches (no sphere is passed over or under).
pub const ALL_ALTITUDES: [f64; 2] = [f64::NEG_INFINITY, f64::INFINITY];

/// The slowest climb or descent a route's altitudes are assumed to change at, m/s: an
/// aircraft told to change altitude gets there at least this fast (the simulator's
/// climbs at 4 m/s, an autopilot's default climb limit is about 5), so the altitudes
/// between where it may still be and where it is told to go bound where it is.
pub const MIN_CLIMB_RATE_MPS: f64 = 2.0;

/// The altitudes the aircraft may be at along each leg of `tail`, flown from `start_p_m`
/// at altitude `start_alt_m` at `speed_mps`: leg `i` (toward `tail[i]`) spans every
/// altitude between those the aircraft may have at its start and `tail[i]`'s. Where it may
/// be at a leg's end moves toward the item's altitude at [`MIN_CLIMB_RATE_MPS`] over the
/// leg's straight length (a flown leg is no shorter, so no slower an aircraft is ever
/// outside the band), so a short leg after a climb still spans the climb's start.
pub fn leg_bands(
    start_p_m: Point,
    start_alt_m: f64,
    tail: &[crate::stack::StackItem],
    speed_mps: f64,
) -> Vec<[f64; 2]> {
    let (mut lo, mut hi) = (start_alt_m, start_alt_m);
    let mut prev = start_p_m;
    tail.iter()
        .map(|it| {
            let target = it.alt_m;
            let band = [lo.min(target), hi.max(target)];
            let d = if speed_mps > 0.0 {
                MIN_CLIMB_RATE_MPS * dist(prev, it.p_m) / speed_mps
            } else {
                0.0
            };
            let toward = |z: f64| z + (target - z).clamp(-d, d);
            let (a, b) = (toward(lo), toward(hi));
            lo = a.min(b).min(target);
            hi = a.max(b).max(target);
            prev = it.p_m;
            band
        })
        .collect()
}

impl LegEnv<'_> {
    /// This environment for a leg flown within `band_m` (see [`LegEnv::band_m`]).
    pub fn in_band(self, band_m: [f64; 2]) -> Self {
        Self {
            band_m,
            band_hint: self.risk.band_hint(band_m),
            ..self
        }
    }

    /// The risk at `p_m` at `t_s` for this leg's altitudes.
    #[inline]
    pub fn risk_at(&self, p_m: Point, t_s: f64) -> f64 {
        self.risk
            .risk_in_band_hinted(p_m, t_s, self.band_m, self.band_hint)
    }

    /// A conservative bound of [`LegEnv::risk_at`] along `a_m -> b_m` flown from `t0_s` to
    /// `t1_s`.
    pub fn segment_risk_bound(&self, a_m: Point, b_m: Point, t0_s: f64, t1_s: f64) -> f64 {
        self.risk
            .segment_risk_bound_in_band(a_m, b_m, t0_s, t1_s, self.band_m)
    }
}

impl std::fmt::Debug for LegEnv<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LegEnv")
            .field("alt_m", &self.alt_m)
            .field("band_m", &self.band_m)
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
                    let r = self.risk_at(lerp(a, b, i as f64 / n as f64), ti);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stack::StackItem;

    /// The altitudes an aircraft climbing at `rate` m/s (and flying at 20 m/s) passes
    /// through along `tail` from `start_alt` at the origin, sampled every metre.
    fn flown_altitudes(start_alt: f64, tail: &[StackItem], rate: f64) -> Vec<[f64; 2]> {
        let (mut z, mut prev) = (start_alt, [0.0, 0.0]);
        tail.iter()
            .map(|it| {
                let (mut lo, mut hi) = (z, z);
                let n = dist(prev, it.p_m).ceil().max(1.0) as usize;
                let step = dist(prev, it.p_m) / n as f64 / 20.0 * rate;
                for _ in 0..n {
                    z += (it.alt_m - z).clamp(-step, step);
                    lo = lo.min(z);
                    hi = hi.max(z);
                }
                prev = it.p_m;
                [lo, hi]
            })
            .collect()
    }

    #[test]
    fn each_legs_band_holds_the_altitudes_an_aircraft_climbing_at_least_the_slowest_rate_flies() {
        // A climb of 100 m over 200 m (10 s at 20 m/s, 20 m at the slowest rate), then short
        // legs at the new altitude, a long one, and a descent.
        let tail = [
            StackItem::mission(0, [200.0, 0.0], 200.0),
            StackItem::avoid([250.0, 0.0], 200.0),
            StackItem::avoid([300.0, 50.0], 200.0),
            StackItem::mission(1, [2000.0, 50.0], 200.0),
            StackItem::mission(2, [2100.0, 50.0], 150.0),
        ];
        let bands = leg_bands([0.0, 0.0], 100.0, &tail, 20.0);
        // The leg after the climb still spans where a slow climber is (about 120-140 m).
        assert_eq!(bands[0], [100.0, 200.0]);
        assert!(bands[1][0] < 125.0 && bands[2][0] < 130.0, "{bands:?}");
        // After 1.7 km every climber has arrived: the band is the altitude alone.
        assert_eq!(bands[4], [150.0, 200.0]);
        for rate in [MIN_CLIMB_RATE_MPS, 3.0, 4.0, 10.0, 100.0] {
            for (i, (f, b)) in flown_altitudes(100.0, &tail, rate)
                .iter()
                .zip(&bands)
                .enumerate()
            {
                assert!(
                    b[0] <= f[0] + 1e-9 && f[1] <= b[1] + 1e-9,
                    "leg {i} at {rate} m/s flies {f:?}, outside its band {b:?}"
                );
            }
        }
    }
}
