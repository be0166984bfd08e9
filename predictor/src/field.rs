//! The contract between the predictor and the planner: anything that answers
//! `risk(point, t)` is a risk field.
//!
//! # Units
//! Points are ENU metres `[east_m, north_m]`; `t_s` is mission time in seconds (the same
//! clock as the telemetry the predictor was fed).

/// A probability field over the plane and time: `risk` is the probability that the point
/// lies inside some obstacle (plus its safety buffer) at time `t_s`, in `[0, 1]`.
///
/// Implementations must be cheap to query (the planner calls it millions of times per
/// plan) and thread-safe.
pub trait RiskField: Send + Sync {
    /// Probability in `[0, 1]` that `p_m` (ENU metres) is inside an obstacle at `t_s`.
    fn risk(&self, p_m: [f64; 2], t_s: f64) -> f64;

    /// A conservative upper bound of `risk` along the segment `a_m -> b_m` traversed
    /// between `t0_s` and `t1_s`. The default samples the segment densely; implementations
    /// may answer faster from coarser data.
    fn segment_risk_bound(&self, a_m: [f64; 2], b_m: [f64; 2], t0_s: f64, t1_s: f64) -> f64 {
        let steps = 16;
        let mut worst: f64 = 0.0;
        for i in 0..=steps {
            let f = f64::from(i) / f64::from(steps);
            let p = [
                a_m[0] + (b_m[0] - a_m[0]) * f,
                a_m[1] + (b_m[1] - a_m[1]) * f,
            ];
            worst = worst.max(self.risk(p, t0_s + (t1_s - t0_s) * f));
        }
        worst
    }

    /// `risk` for an aircraft whose altitude lies within `band_m` = `[lo, hi]` metres MSL
    /// there: obstacles that cannot reach those altitudes are left out (a leg flown above
    /// or below a sphere passes it). The default leaves nothing out (every obstacle counts
    /// at every altitude), which is conservative.
    fn risk_in_band(&self, p_m: [f64; 2], t_s: f64, band_m: [f64; 2]) -> f64 {
        let _ = band_m;
        self.risk(p_m, t_s)
    }

    /// A summary of `band_m` that [`RiskField::risk_in_band_hinted`] reads faster with,
    /// for many reads in one band (a leg's); [`NO_BAND_HINT`] when the field has none
    /// (the default).
    fn band_hint(&self, band_m: [f64; 2]) -> u64 {
        let _ = band_m;
        NO_BAND_HINT
    }

    /// [`RiskField::risk_in_band`], given `hint` = [`RiskField::band_hint`] of this field
    /// for the same band (or [`NO_BAND_HINT`]). The default ignores the hint.
    fn risk_in_band_hinted(&self, p_m: [f64; 2], t_s: f64, band_m: [f64; 2], hint: u64) -> f64 {
        let _ = hint;
        self.risk_in_band(p_m, t_s, band_m)
    }

    /// [`RiskField::segment_risk_bound`] for an aircraft within `band_m` (see
    /// [`RiskField::risk_in_band`]); still a conservative bound of `risk_in_band` along
    /// the segment. The default ignores the band.
    fn segment_risk_bound_in_band(
        &self,
        a_m: [f64; 2],
        b_m: [f64; 2],
        t0_s: f64,
        t1_s: f64,
        band_m: [f64; 2],
    ) -> f64 {
        let _ = band_m;
        self.segment_risk_bound(a_m, b_m, t0_s, t1_s)
    }
}

/// [`RiskField::band_hint`] of a field without hints: reads work the band out
/// themselves.
pub const NO_BAND_HINT: u64 = u64::MAX;

/// The empty field: no obstacle anywhere, ever.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoRisk;

impl RiskField for NoRisk {
    fn risk(&self, _p_m: [f64; 2], _t_s: f64) -> f64 {
        0.0
    }
    fn segment_risk_bound(&self, _a: [f64; 2], _b: [f64; 2], _t0: f64, _t1: f64) -> f64 {
        0.0
    }
}

impl<F: RiskField + ?Sized> RiskField for &F {
    fn risk(&self, p_m: [f64; 2], t_s: f64) -> f64 {
        (**self).risk(p_m, t_s)
    }
    fn segment_risk_bound(&self, a_m: [f64; 2], b_m: [f64; 2], t0_s: f64, t1_s: f64) -> f64 {
        (**self).segment_risk_bound(a_m, b_m, t0_s, t1_s)
    }
    fn risk_in_band(&self, p_m: [f64; 2], t_s: f64, band_m: [f64; 2]) -> f64 {
        (**self).risk_in_band(p_m, t_s, band_m)
    }
    fn band_hint(&self, band_m: [f64; 2]) -> u64 {
        (**self).band_hint(band_m)
    }
    fn risk_in_band_hinted(&self, p_m: [f64; 2], t_s: f64, band_m: [f64; 2], hint: u64) -> f64 {
        (**self).risk_in_band_hinted(p_m, t_s, band_m, hint)
    }
    fn segment_risk_bound_in_band(
        &self,
        a_m: [f64; 2],
        b_m: [f64; 2],
        t0_s: f64,
        t1_s: f64,
        band_m: [f64; 2],
    ) -> f64 {
        (**self).segment_risk_bound_in_band(a_m, b_m, t0_s, t1_s, band_m)
    }
}
