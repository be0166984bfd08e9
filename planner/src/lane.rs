//! The lane of an obstacle faster than the aircraft (issue 10, "the pursuer from behind").
//!
//! The risk map reads the probability that a point is inside an obstacle at a time. For a
//! sphere that turns at random, that probability is spread over a fan: every point of the
//! fan reads little, though the sphere will be somewhere in it, and a route that stays in
//! its lane meets it with a chance far above any single point's. When the sphere is
//! faster than the aircraft it cannot be outrun, and the hits left at 14 m/s were such
//! spheres closing from behind, read at 0.03-0.12 on every plan until seconds before
//! (Webster Field with mixed spheres, seeds 2398 and 2832).
//!
//! A [`LaneField`] reads a field with, for each such obstacle, its lane: the disc of its
//! radius plus the map's buffer carried along its present velocity (straight, constant
//! speed) for the first seconds of the plan, at a fixed risk
//! ([`crate::PlanParams::chase_lane_risk`]) wherever the field reads less. A route that
//! meets the lane within those seconds is then not clear (in danger when the lane's risk
//! is above [`crate::PlanParams::danger_risk`]), and the detours and escapes that leave
//! it rank first, as for any near-term risk.
//!
//! Contract:
//! - A lane is a deterministic disc moving at constant velocity: `risk` reads the lane's
//!   risk where the disc holds the point at the time asked, within the lane's window; the
//!   field's own risk elsewhere and whenever it is higher.
//! - `segment_risk_bound` is an exact bound for the lanes (the closest approach of a
//!   point moving along the segment to each moving disc), so it stays conservative.
//! - Band reads leave out a lane whose altitude reach misses the band, as the map leaves
//!   out the obstacle.
//!
//! # Units
//! ENU metres, seconds on the field's clock.

use predictor::RiskField;

use crate::geometry::{Point, dist_point_segment};

/// One obstacle's lane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lane {
    /// Where the obstacle is at `at_s`, ENU metres.
    pub p_m: Point,
    /// When it is there, seconds.
    pub at_s: f64,
    /// Its velocity, ENU m/s.
    pub v_mps: [f64; 2],
    /// Its radius plus the map's buffer, metres.
    pub radius_m: f64,
    /// The window the lane holds in, seconds: `[from, until]`.
    pub window_s: [f64; 2],
    /// The lowest and highest altitude it can touch, metres MSL.
    pub reach_m: [f64; 2],
    /// The risk read inside it.
    pub risk: f64,
}

impl Lane {
    fn centre(&self, t_s: f64) -> Point {
        let dt = t_s - self.at_s;
        [
            self.p_m[0] + self.v_mps[0] * dt,
            self.p_m[1] + self.v_mps[1] * dt,
        ]
    }

    fn in_band(&self, band_m: Option<[f64; 2]>) -> bool {
        band_m.is_none_or(|b| self.reach_m[0] <= b[1] && self.reach_m[1] >= b[0])
    }

    /// The lane's risk at `p_m` at `t_s` (0 outside it).
    pub fn risk_at(&self, p_m: Point, t_s: f64) -> f64 {
        if t_s < self.window_s[0] || t_s > self.window_s[1] {
            return 0.0;
        }
        let c = self.centre(t_s);
        if (p_m[0] - c[0]).hypot(p_m[1] - c[1]) <= self.radius_m {
            self.risk
        } else {
            0.0
        }
    }

    /// The lane's risk when a point moving from `a_m` at `t0_s` to `b_m` at `t1_s` (at
    /// constant velocity) is inside it at some time of the window: exact.
    pub fn segment_risk(&self, a_m: Point, b_m: Point, t0_s: f64, t1_s: f64) -> f64 {
        let (lo, hi) = (t0_s.max(self.window_s[0]), t1_s.min(self.window_s[1]));
        if lo > hi {
            return 0.0;
        }
        let span = t1_s - t0_s;
        let at = |t: f64| {
            let f = (t - t0_s) / span;
            [
                a_m[0] + (b_m[0] - a_m[0]) * f,
                a_m[1] + (b_m[1] - a_m[1]) * f,
            ]
        };
        // The point relative to the disc's centre moves linearly from `r0` to `r1` (a
        // segment with no duration: the whole of it at that time).
        let (c0, c1, p0, p1) = if span > 0.0 {
            (self.centre(lo), self.centre(hi), at(lo), at(hi))
        } else {
            (self.centre(lo), self.centre(lo), a_m, b_m)
        };
        let r0 = [p0[0] - c0[0], p0[1] - c0[1]];
        let r1 = [p1[0] - c1[0], p1[1] - c1[1]];
        let closest = dist_point_segment([0.0, 0.0], r0, r1);
        if closest <= self.radius_m {
            self.risk
        } else {
            0.0
        }
    }
}

/// A field read with lanes over it (see the module docs).
pub struct LaneField<'a> {
    inner: &'a dyn RiskField,
    lanes: Vec<Lane>,
}

impl<'a> LaneField<'a> {
    /// `inner` with `lanes` over it.
    pub fn new(inner: &'a dyn RiskField, lanes: Vec<Lane>) -> Self {
        Self { inner, lanes }
    }

    /// The lanes.
    pub fn lanes(&self) -> &[Lane] {
        &self.lanes
    }

    fn lanes_at(&self, p_m: Point, t_s: f64, band_m: Option<[f64; 2]>) -> f64 {
        self.lanes
            .iter()
            .filter(|l| l.in_band(band_m))
            .map(|l| l.risk_at(p_m, t_s))
            .fold(0.0, f64::max)
    }

    fn lanes_along(
        &self,
        a_m: Point,
        b_m: Point,
        t0_s: f64,
        t1_s: f64,
        band_m: Option<[f64; 2]>,
    ) -> f64 {
        self.lanes
            .iter()
            .filter(|l| l.in_band(band_m))
            .map(|l| l.segment_risk(a_m, b_m, t0_s, t1_s))
            .fold(0.0, f64::max)
    }
}

impl RiskField for LaneField<'_> {
    fn risk(&self, p_m: [f64; 2], t_s: f64) -> f64 {
        self.inner.risk(p_m, t_s).max(self.lanes_at(p_m, t_s, None))
    }

    fn segment_risk_bound(&self, a_m: [f64; 2], b_m: [f64; 2], t0_s: f64, t1_s: f64) -> f64 {
        self.inner
            .segment_risk_bound(a_m, b_m, t0_s, t1_s)
            .max(self.lanes_along(a_m, b_m, t0_s, t1_s, None))
    }

    fn risk_in_band(&self, p_m: [f64; 2], t_s: f64, band_m: [f64; 2]) -> f64 {
        self.inner
            .risk_in_band(p_m, t_s, band_m)
            .max(self.lanes_at(p_m, t_s, Some(band_m)))
    }

    fn band_hint(&self, band_m: [f64; 2]) -> u64 {
        self.inner.band_hint(band_m)
    }

    fn risk_in_band_hinted(&self, p_m: [f64; 2], t_s: f64, band_m: [f64; 2], hint: u64) -> f64 {
        self.inner
            .risk_in_band_hinted(p_m, t_s, band_m, hint)
            .max(self.lanes_at(p_m, t_s, Some(band_m)))
    }

    fn segment_risk_bound_in_band(
        &self,
        a_m: [f64; 2],
        b_m: [f64; 2],
        t0_s: f64,
        t1_s: f64,
        band_m: [f64; 2],
    ) -> f64 {
        self.inner
            .segment_risk_bound_in_band(a_m, b_m, t0_s, t1_s, band_m)
            .max(self.lanes_along(a_m, b_m, t0_s, t1_s, Some(band_m)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use predictor::NoRisk;
    use proptest::prelude::*;

    /// A sphere of 30 m (with the buffer) at the origin at t = 10 s, flying east at 20 m/s,
    /// its lane held from 10 to 20 s, reaching 50-150 m.
    fn east() -> Lane {
        Lane {
            p_m: [0.0, 0.0],
            at_s: 10.0,
            v_mps: [20.0, 0.0],
            radius_m: 30.0,
            window_s: [10.0, 20.0],
            reach_m: [50.0, 150.0],
            risk: 0.5,
        }
    }

    #[test]
    fn a_lane_holds_the_disc_carried_on_at_its_velocity_within_its_window() {
        let l = east();
        // 5 s on, the disc is centred at x = 100.
        assert_eq!(l.risk_at([100.0, 29.0], 15.0), 0.5);
        assert_eq!(l.risk_at([71.0, 0.0], 15.0), 0.5);
        assert_eq!(l.risk_at([100.0, 31.0], 15.0), 0.0);
        assert_eq!(l.risk_at([0.0, 0.0], 15.0), 0.0, "it has moved on");
        // Outside the window nothing: before it, and after it where the disc would be.
        assert_eq!(l.risk_at([200.0, 0.0], 20.0), 0.5);
        assert_eq!(l.risk_at([220.0, 0.0], 21.0), 0.0);
        assert_eq!(l.risk_at([-20.0, 0.0], 9.0), 0.0);
    }

    #[test]
    fn a_lane_field_reads_the_worse_of_the_field_and_the_lane_and_leaves_out_a_lane_out_of_the_band()
     {
        struct Flat(f64);
        impl RiskField for Flat {
            fn risk(&self, _: [f64; 2], _: f64) -> f64 {
                self.0
            }
        }
        let low = Flat(0.2);
        let f = LaneField::new(&low, vec![east()]);
        assert_eq!(f.risk([100.0, 0.0], 15.0), 0.5);
        assert_eq!(f.risk([100.0, 100.0], 15.0), 0.2);
        let high = Flat(0.9);
        assert_eq!(
            LaneField::new(&high, vec![east()]).risk([100.0, 0.0], 15.0),
            0.9
        );
        // A leg flown at 200-220 m passes over it; one at 140-160 m does not.
        assert_eq!(f.risk_in_band([100.0, 0.0], 15.0, [200.0, 220.0]), 0.2);
        assert_eq!(f.risk_in_band([100.0, 0.0], 15.0, [140.0, 160.0]), 0.5);
        let hint = f.band_hint([200.0, 220.0]);
        assert_eq!(
            f.risk_in_band_hinted([100.0, 0.0], 15.0, [200.0, 220.0], hint),
            0.2
        );
        assert_eq!(
            f.segment_risk_bound_in_band(
                [100.0, -100.0],
                [100.0, 100.0],
                14.0,
                16.0,
                [200.0, 220.0]
            ),
            0.2_f64.max(Flat(0.2).segment_risk_bound([100.0, -100.0], [100.0, 100.0], 14.0, 16.0))
        );
        assert_eq!(
            f.segment_risk_bound([100.0, -100.0], [100.0, 100.0], 14.0, 16.0),
            0.5
        );
        // Nothing under it: the lane alone.
        let none = LaneField::new(&NoRisk, vec![east()]);
        assert_eq!(none.risk([100.0, 0.0], 15.0), 0.5);
        assert_eq!(none.risk([100.0, 0.0], 25.0), 0.0);
    }

    #[test]
    fn a_segment_crossing_the_lane_after_the_disc_has_gone_by_is_clear() {
        let l = east();
        // Across x = 100 from south to north, 14-16 s: the disc is there at 15 s.
        assert_eq!(
            l.segment_risk([100.0, -100.0], [100.0, 100.0], 14.0, 16.0),
            0.5
        );
        // The same crossing 3 s later: the disc is 60 m further east.
        assert_eq!(
            l.segment_risk([100.0, -100.0], [100.0, 100.0], 17.0, 19.0),
            0.0
        );
        // Flying along ahead of it at its own speed, 40 m ahead: never caught.
        assert_eq!(l.segment_risk([40.0, 0.0], [240.0, 0.0], 10.0, 20.0), 0.0);
        // At 15 m/s, 40 m ahead: caught after 2 s.
        assert_eq!(l.segment_risk([40.0, 0.0], [190.0, 0.0], 10.0, 20.0), 0.5);
        // Only the window counts: at 6 m/s from 200 m ahead, caught at 22.1 s, after it;
        // from 160 m ahead at 19.3 s, within it.
        assert_eq!(l.segment_risk([200.0, 0.0], [290.0, 0.0], 10.0, 25.0), 0.0);
        assert_eq!(l.segment_risk([160.0, 0.0], [250.0, 0.0], 10.0, 25.0), 0.5);
    }

    proptest! {
        /// The exact segment read agrees with dense point reads along the segment.
        #[test]
        fn the_segment_read_agrees_with_dense_point_reads(
            ax in -300.0..300.0_f64, ay in -300.0..300.0_f64,
            bx in -300.0..300.0_f64, by in -300.0..300.0_f64,
            t0 in 5.0..22.0_f64, dur in 0.0..8.0_f64,
            vx in -25.0..25.0_f64, vy in -25.0..25.0_f64,
        ) {
            let l = Lane { v_mps: [vx, vy], ..east() };
            let (a, b, t1) = ([ax, ay], [bx, by], t0 + dur);
            let exact = l.segment_risk(a, b, t0, t1);
            let n = 4000;
            let mut hit = false;
            let mut near = false;
            for i in 0..=n {
                let f = f64::from(i) / f64::from(n);
                let p = [ax + (bx - ax) * f, ay + (by - ay) * f];
                let t = t0 + dur * f;
                if l.risk_at(p, t) > 0.0 {
                    hit = true;
                }
                let bigger = Lane { radius_m: l.radius_m + 1.0, ..l };
                if bigger.risk_at(p, t) > 0.0 {
                    near = true;
                }
            }
            // Dense reads inside: the segment read says so; the segment read inside: dense
            // reads find it within a metre (the sampling's own resolution).
            prop_assert!(!hit || exact == 0.5, "dense reads hit, segment read {exact}");
            prop_assert!(exact == 0.0 || near, "segment read {exact}, no dense read near");
        }
    }
}
