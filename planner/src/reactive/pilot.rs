//! The BlackFly Pilot (seed 001, section 4 "Pilot Module: Adaptive Bezier Path Planning"):
//! turn the Offset Algorithm's lateral deviation into a smooth path out to the offset and
//! back to the goal line.
//!
//! # Frame
//!
//! Aircraft-relative: origin at the aircraft, `y_m` forward along the true waypoint path
//! (the goal line is `x = 0`), `x_m` lateral with **left positive** (the same sign as the
//! avoiders' angles and `deviation_m`).
//!
//! # Construction
//!
//! With deviation `d`, scan range `l`, goal distance `G`, `g = goal_fraction * G`
//! (0.6 as in the seed) and the return overhead `delta` (default `G - g`, so the path
//! rejoins the goal line at the goal):
//!
//! - `P0 = (0, 0)`, `P1 = (d, l)` (offset point), `P = (d, g)` (projected point),
//!   `P2 = (0, g + delta)` (return anchor), exactly the seed's points;
//! - the seed gives four points but a quadratic `B(t) = (1-t)^2 P0 + 2(1-t)t P1 + t^2 P2`
//!   takes three, and says the curve is "concatenated": here it is two quadratics,
//!   **away** `P0 -> (P1) -> P` and **back** `P -> (Q) -> P2` with `Q = (d, g + delta/2)`.
//!   The away segment leaves along `P1 - P0` (toward the offset point) and arrives at `P`
//!   heading straight forward (`P - P1 = (0, g - l)`); `Q` lies straight ahead of `P`, so the
//!   join is tangent-continuous (G1), and the back segment reaches the goal line at `P2`
//!   along `P2 - Q = (-d, delta/2)`.
//! - `l` is capped at `0.8 g` so that `P1` stays before `P` (otherwise the away segment would
//!   overshoot and come back).
//!
//! Heuristics (seed 001 4.1 names them; the rules are this module's):
//! 1. **snap-back**: `|d| <= snap_back_m` means the way is clear: `d = 0`, the path is the
//!    goal line itself (straight, all points at `x = 0`);
//! 2. **max deviation**: `|d| <= max_deviation_m`;
//! 3. **goal funnel**: `|d| <= funnel_ratio * G`, so the permitted offset narrows as the goal
//!    approaches and the path is funnelled onto the goal.
//!
//! The deviation cost `C(d) = deviation_cost_weight * d^2` (seed 001 4.3) is reported with the
//! plan, so a caller can compare alternatives.
//!
//! # Example
//! ```
//! use planner::reactive::{PilotInput, PilotParams, pilot_plan};
//! let plan = pilot_plan(&PilotInput::new(2.0, 5.0, 50.0), &PilotParams::default()).unwrap();
//! // g = 0.6 * 50 = 30, P2 = (0, 50)
//! assert_eq!((plan.p.x_m, plan.p.y_m), (2.0, 30.0));
//! assert_eq!((plan.p2.x_m, plan.p2.y_m), (0.0, 50.0));
//! ```

/// `P1`'s forward distance is capped at this fraction of `g`.
pub const MAX_OFFSET_FRACTION: f64 = 0.8;

/// A point of the path, aircraft-relative: `x_m` lateral (left positive), `y_m` forward.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PathPoint {
    /// Lateral offset, metres, left positive.
    pub x_m: f64,
    /// Forward distance, metres.
    pub y_m: f64,
}

impl PathPoint {
    /// The point `(x_m, y_m)`.
    pub const fn new(x_m: f64, y_m: f64) -> Self {
        Self { x_m, y_m }
    }
}

/// What the pilot plans from.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PilotInput {
    /// Requested lateral deviation, metres, left positive (the offset decision's `deviation_m`).
    pub deviation_m: f64,
    /// Scan range `l` (look-ahead), metres, > 0.
    pub scan_range_m: f64,
    /// Distance to the goal along the goal line, metres, > 0.
    pub goal_distance_m: f64,
}

impl PilotInput {
    /// A pilot input.
    pub const fn new(deviation_m: f64, scan_range_m: f64, goal_distance_m: f64) -> Self {
        Self {
            deviation_m,
            scan_range_m,
            goal_distance_m,
        }
    }
}

/// Pilot parameters (the seed's "heuristics").
///
/// Defaults: `goal_fraction` 0.6 (the seed's `g = 0.6 x goal_distance`), return overhead
/// `None` (= to the goal), `max_deviation_m` 30, `snap_back_m` 0.25, `funnel_ratio` 0.5,
/// `deviation_cost_weight` 1.0.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct PilotParams {
    /// `g = goal_fraction * goal_distance`, in `(0, 1)`.
    pub goal_fraction: f64,
    /// `delta` in `P2 = (0, g + delta)`, metres; `None` = `goal_distance - g`.
    pub return_overhead_m: Option<f64>,
    /// Largest lateral deviation allowed, metres.
    pub max_deviation_m: f64,
    /// Deviations up to this size snap back to the goal line, metres.
    pub snap_back_m: f64,
    /// Goal funnel: `|d| <= funnel_ratio * goal_distance`.
    pub funnel_ratio: f64,
    /// Weight `k` of the deviation cost `C(d) = k d^2`.
    pub deviation_cost_weight: f64,
}

impl Default for PilotParams {
    fn default() -> Self {
        Self {
            goal_fraction: 0.6,
            return_overhead_m: None,
            max_deviation_m: 30.0,
            snap_back_m: 0.25,
            funnel_ratio: 0.5,
            deviation_cost_weight: 1.0,
        }
    }
}

impl PilotParams {
    setters! {
        /// Set the maximum deviation (metres).
        with_max_deviation_m(max_deviation_m: f64);
        /// Set the snap-back size (metres).
        with_snap_back_m(snap_back_m: f64);
        /// Set the goal-funnel ratio.
        with_funnel_ratio(funnel_ratio: f64);
        /// Set `goal_fraction` (the seed's 0.6).
        with_goal_fraction(goal_fraction: f64);
    }
    /// Set the return overhead `delta` (metres).
    pub fn with_return_overhead_m(mut self, v: f64) -> Self {
        self.return_overhead_m = Some(v);
        self
    }

    /// Check the parameters.
    ///
    /// # Errors
    /// [`PilotError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<(), PilotError> {
        let bad =
            |name: &'static str, value: f64| Err(PilotError::InvalidParameter { name, value });
        if !(self.goal_fraction > 0.0 && self.goal_fraction < 1.0) {
            return bad("goal_fraction", self.goal_fraction);
        }
        if let Some(v) = self.return_overhead_m
            && !(v.is_finite() && v > 0.0)
        {
            return bad("return_overhead_m", v);
        }
        if self.max_deviation_m.is_nan() || self.max_deviation_m < 0.0 {
            return bad("max_deviation_m", self.max_deviation_m);
        }
        if !(self.snap_back_m.is_finite() && self.snap_back_m >= 0.0) {
            return bad("snap_back_m", self.snap_back_m);
        }
        if self.funnel_ratio.is_nan() || self.funnel_ratio < 0.0 {
            return bad("funnel_ratio", self.funnel_ratio);
        }
        if !(self.deviation_cost_weight.is_finite() && self.deviation_cost_weight >= 0.0) {
            return bad("deviation_cost_weight", self.deviation_cost_weight);
        }
        Ok(())
    }
}

/// Bad pilot input. Fix the named value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PilotError {
    /// An input is not finite or out of range (`deviation_m` finite, `scan_range_m` and
    /// `goal_distance_m` positive and finite).
    #[error("{name} = {value} is out of range")]
    InvalidInput {
        /// Field name.
        name: &'static str,
        /// The bad value.
        value: f64,
    },
    /// A parameter is out of range.
    #[error("pilot parameter {name} = {value} is out of range")]
    InvalidParameter {
        /// Field name.
        name: &'static str,
        /// The bad value.
        value: f64,
    },
}

/// Which heuristic changed the requested deviation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum PilotLimit {
    /// Small deviation: snapped back to the goal line.
    SnapBack,
    /// Clamped to `max_deviation_m`.
    MaxDeviation,
    /// Clamped by the goal funnel.
    GoalFunnel,
}

/// The planned two-segment Bezier path.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PilotPlan {
    /// The deviation asked for.
    pub requested_deviation_m: f64,
    /// The deviation used after the heuristics.
    pub deviation_m: f64,
    /// The heuristic that changed it, if any.
    pub limited_by: Option<PilotLimit>,
    /// Start, the aircraft: `(0, 0)`.
    pub p0: PathPoint,
    /// Offset point `(d, l)`, control of the away segment.
    pub p1: PathPoint,
    /// Projected point `(d, g)`, end of the away segment.
    pub p: PathPoint,
    /// Control of the back segment `(d, g + delta/2)`.
    pub q: PathPoint,
    /// Return anchor `(0, g + delta)`.
    pub p2: PathPoint,
    /// Deviation cost `C(d) = k d^2`.
    pub cost: f64,
}

fn quad(a: PathPoint, b: PathPoint, c: PathPoint, t: f64) -> PathPoint {
    let u = 1.0 - t;
    PathPoint::new(
        u * u * a.x_m + 2.0 * u * t * b.x_m + t * t * c.x_m,
        u * u * a.y_m + 2.0 * u * t * b.y_m + t * t * c.y_m,
    )
}

impl PilotPlan {
    /// The point at path parameter `s` in `[0, 2]`: `[0, 1]` the away segment, `[1, 2]` the
    /// back segment (clamped outside).
    pub fn point_at(&self, s: f64) -> PathPoint {
        let s = s.clamp(0.0, 2.0);
        if s <= 1.0 {
            quad(self.p0, self.p1, self.p, s)
        } else {
            quad(self.p, self.q, self.p2, s - 1.0)
        }
    }

    /// Sample `samples_per_segment + 1` points per segment into `out` (cleared first; the
    /// shared point `P` appears once): `2 * samples_per_segment + 1` points from `P0` to `P2`.
    /// `samples_per_segment` 0 is treated as 1.
    pub fn sample_into(&self, samples_per_segment: usize, out: &mut Vec<PathPoint>) {
        let m = samples_per_segment.max(1);
        out.clear();
        out.reserve(2 * m + 1);
        for i in 0..=m {
            out.push(quad(self.p0, self.p1, self.p, i as f64 / m as f64));
        }
        for i in 1..=m {
            out.push(quad(self.p, self.q, self.p2, i as f64 / m as f64));
        }
    }

    /// [`sample_into`](Self::sample_into) into a new vector.
    pub fn sample(&self, samples_per_segment: usize) -> Vec<PathPoint> {
        let mut v = Vec::new();
        self.sample_into(samples_per_segment, &mut v);
        v
    }
}

/// Plan the pilot path for one cycle. Pure and allocation-free.
///
/// # Errors
/// [`PilotError`] when an input is not finite or not positive where required, or a
/// parameter is out of range.
pub fn pilot_plan(input: &PilotInput, params: &PilotParams) -> Result<PilotPlan, PilotError> {
    params.validate()?;
    let bad = |name: &'static str, value: f64| Err(PilotError::InvalidInput { name, value });
    if !input.deviation_m.is_finite() {
        return bad("deviation_m", input.deviation_m);
    }
    if !(input.scan_range_m.is_finite() && input.scan_range_m > 0.0) {
        return bad("scan_range_m", input.scan_range_m);
    }
    if !(input.goal_distance_m.is_finite() && input.goal_distance_m > 0.0) {
        return bad("goal_distance_m", input.goal_distance_m);
    }
    let goal = input.goal_distance_m;
    let g = params.goal_fraction * goal;
    let delta = params.return_overhead_m.unwrap_or(goal - g);
    let l = input.scan_range_m.min(MAX_OFFSET_FRACTION * g);

    let requested = input.deviation_m;
    let mut d = requested;
    let mut limited_by = None;
    if d.abs() <= params.snap_back_m {
        if d != 0.0 {
            limited_by = Some(PilotLimit::SnapBack);
        }
        d = 0.0;
    }
    if d.abs() > params.max_deviation_m {
        d = params.max_deviation_m.copysign(d);
        limited_by = Some(PilotLimit::MaxDeviation);
    }
    let funnel = params.funnel_ratio * goal;
    if d.abs() > funnel {
        d = funnel.copysign(d);
        limited_by = Some(PilotLimit::GoalFunnel);
    }

    Ok(PilotPlan {
        requested_deviation_m: requested,
        deviation_m: d,
        limited_by,
        p0: PathPoint::new(0.0, 0.0),
        p1: PathPoint::new(d, l),
        p: PathPoint::new(d, g),
        q: PathPoint::new(d, g + delta / 2.0),
        p2: PathPoint::new(0.0, g + delta),
        cost: params.deviation_cost_weight * d * d,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// Derivative of a quadratic Bezier: B'(t) = 2(1-t)(b-a) + 2t(c-b).
    fn dquad(a: PathPoint, b: PathPoint, c: PathPoint, t: f64) -> (f64, f64) {
        let u = 1.0 - t;
        (
            2.0 * u * (b.x_m - a.x_m) + 2.0 * t * (c.x_m - b.x_m),
            2.0 * u * (b.y_m - a.y_m) + 2.0 * t * (c.y_m - b.y_m),
        )
    }

    #[test]
    fn control_points_follow_the_seed() {
        // d = 3, l = 5, G = 50: g = 30, delta = 20, P1 = (3, 5), P = (3, 30),
        // Q = (3, 40), P2 = (0, 50); cost = 3^2 = 9
        let plan = pilot_plan(&PilotInput::new(3.0, 5.0, 50.0), &PilotParams::default()).unwrap();
        assert_eq!(plan.p0, PathPoint::new(0.0, 0.0));
        assert_eq!(plan.p1, PathPoint::new(3.0, 5.0));
        assert_eq!(plan.p, PathPoint::new(3.0, 30.0));
        assert_eq!(plan.q, PathPoint::new(3.0, 40.0));
        assert_eq!(plan.p2, PathPoint::new(0.0, 50.0));
        assert_eq!(plan.cost, 9.0);
        assert_eq!(plan.limited_by, None);
    }

    #[test]
    fn sampled_path_ends_are_p0_and_p2_and_passes_p() {
        let plan = pilot_plan(&PilotInput::new(-4.0, 8.0, 100.0), &PilotParams::default()).unwrap();
        let pts = plan.sample(10);
        assert_eq!(pts.len(), 21);
        assert_eq!(pts[0], PathPoint::new(0.0, 0.0));
        // g = 60, P2 = (0, 100)
        assert_eq!(pts[10], PathPoint::new(-4.0, 60.0));
        assert_relative_eq!(pts[20].x_m, 0.0, epsilon = 1e-12);
        assert_relative_eq!(pts[20].y_m, 100.0, epsilon = 1e-12);
        // forward progress is monotone (P1 before P, Q before P2)
        assert!(pts.windows(2).all(|w| w[1].y_m > w[0].y_m));
        // never further out than d on the right side
        assert!(pts.iter().all(|p| p.x_m <= 0.0 && p.x_m >= -4.0 - 1e-12));
    }

    #[test]
    fn tangents_at_the_ends_and_the_join() {
        // d = 2, l = 10, G = 50: P1 = (2, 10), P = (2, 30), Q = (2, 40), P2 = (0, 50)
        let plan = pilot_plan(&PilotInput::new(2.0, 10.0, 50.0), &PilotParams::default()).unwrap();
        // start: B'(0) = 2 (P1 - P0) = (4, 20), toward the offset point
        assert_eq!(dquad(plan.p0, plan.p1, plan.p, 0.0), (4.0, 20.0));
        // end of away: B'(1) = 2 (P - P1) = (0, 40): straight ahead
        assert_eq!(dquad(plan.p0, plan.p1, plan.p, 1.0), (0.0, 40.0));
        // start of back: 2 (Q - P) = (0, 20): same direction -> G1 join
        assert_eq!(dquad(plan.p, plan.q, plan.p2, 0.0), (0.0, 20.0));
        // end: 2 (P2 - Q) = (-4, 20): back toward the goal line, heading atan(4/20) = 11.3 deg
        assert_eq!(dquad(plan.p, plan.q, plan.p2, 1.0), (-4.0, 20.0));
    }

    #[test]
    fn heuristics_limit_the_deviation() {
        let p = PilotParams::default(); // max 30, snap 0.25, funnel 0.5
        // snap-back: 0.2 <= 0.25 -> 0, straight path
        let plan = pilot_plan(&PilotInput::new(0.2, 5.0, 100.0), &p).unwrap();
        assert_eq!(plan.deviation_m, 0.0);
        assert_eq!(plan.limited_by, Some(PilotLimit::SnapBack));
        assert!(plan.sample(8).iter().all(|q| q.x_m == 0.0));
        // max deviation: -45 -> -30 (funnel 0.5 * 100 = 50 does not bind)
        let plan = pilot_plan(&PilotInput::new(-45.0, 5.0, 100.0), &p).unwrap();
        assert_eq!(plan.deviation_m, -30.0);
        assert_eq!(plan.limited_by, Some(PilotLimit::MaxDeviation));
        // funnel: goal 20 m away -> |d| <= 10
        let plan = pilot_plan(&PilotInput::new(25.0, 50.0, 20.0), &p).unwrap();
        assert_eq!(plan.deviation_m, 10.0);
        assert_eq!(plan.limited_by, Some(PilotLimit::GoalFunnel));
        // l capped at 0.8 g: G = 20, g = 12, l = min(50, 9.6) = 9.6
        assert_relative_eq!(plan.p1.y_m, 9.6, epsilon = 1e-12);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

        /// Any valid input: the path starts at the aircraft, ends on the goal line at
        /// `g + delta`, moves forward monotonically and never strays beyond the applied
        /// deviation, which respects every limit.
        #[test]
        fn paths_run_forward_from_the_aircraft_to_the_goal_line(
            d in -200.0f64..200.0,
            l in 0.1f64..200.0,
            goal in 1.0f64..500.0,
            max_dev in 0.0f64..100.0,
            funnel in 0.0f64..2.0,
        ) {
            let p = PilotParams::default().with_max_deviation_m(max_dev).with_funnel_ratio(funnel);
            let plan = pilot_plan(&PilotInput::new(d, l, goal), &p).unwrap();
            let a = plan.deviation_m.abs();
            proptest::prop_assert!(a <= max_dev + 1e-12 && a <= funnel * goal + 1e-12 && a <= d.abs());
            proptest::prop_assert!(plan.deviation_m == 0.0 || plan.deviation_m.signum() == d.signum());
            let pts = plan.sample(12);
            proptest::prop_assert_eq!(pts[0], PathPoint::new(0.0, 0.0));
            let end = pts[pts.len() - 1];
            proptest::prop_assert!(end.x_m.abs() < 1e-9 && (end.y_m - goal).abs() < 1e-9 * goal);
            proptest::prop_assert!(pts.windows(2).all(|w| w[1].y_m > w[0].y_m));
            proptest::prop_assert!(pts.iter().all(|q| q.x_m.abs() <= a + 1e-12));
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let p = PilotParams::default();
        assert!(matches!(
            pilot_plan(&PilotInput::new(f64::NAN, 5.0, 10.0), &p),
            Err(PilotError::InvalidInput {
                name: "deviation_m",
                ..
            })
        ));
        assert!(matches!(
            pilot_plan(&PilotInput::new(1.0, 0.0, 10.0), &p),
            Err(PilotError::InvalidInput {
                name: "scan_range_m",
                ..
            })
        ));
        assert!(matches!(
            pilot_plan(&PilotInput::new(1.0, 5.0, -1.0), &p),
            Err(PilotError::InvalidInput {
                name: "goal_distance_m",
                ..
            })
        ));
        assert!(matches!(
            pilot_plan(&PilotInput::new(1.0, 5.0, 10.0), &p.with_goal_fraction(1.0)),
            Err(PilotError::InvalidParameter {
                name: "goal_fraction",
                ..
            })
        ));
    }
}
