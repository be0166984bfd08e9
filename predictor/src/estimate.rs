//! Estimators refreshed on every observation (seed 002, "Heading, speed, turn radius
//! characterizations"): velocity and heading by a least-squares curve fit over the recent
//! window, speed, signed turn-rate samples taken over the decision interval, and the
//! tightest demonstrated turn radius from circles through sampled triples.
//!
//! Turn samples live on a clock of decision intervals `k * dt_decision`. Sample `k` covers
//! `[k*dt, (k+1)*dt]`: its turn rate is the change of heading between a chord at the
//! interval's start and one at its end (each `heading_half_window_s` long, both inside the
//! interval) divided by the time between the chords' midpoints, and its turn radius is the radius of the circle through the interval's start,
//! middle and end. Sampling per interval rather than per 10 Hz observation makes "memory"
//! mean one turn decision depending on the previous one.
//!
//! # Units
//! Metres, seconds, radians inside; `_deg` / `_dps` only in reported summaries. Turn rates
//! are signed counter-clockwise (left) positive; headings in [`Estimates`] are compass
//! degrees (0 = north, clockwise).

use crate::track::Track;
use geom::dist;
use nalgebra::{Matrix3, Vector3};

/// Estimator parameters, with documented defaults.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct EstimatorConfig {
    /// Window of the velocity fit, seconds. Default 2.0.
    pub velocity_window_s: f64,
    /// Decision interval over which turn-rate samples are taken, seconds. Default 1.0.
    pub decision_interval_s: f64,
    /// Length of the chords that measure the heading at the start and at the end of a
    /// decision interval (both inside the interval), seconds. Must be below
    /// `decision_interval_s`. Default 0.25.
    pub heading_half_window_s: f64,
    /// No interpolation across telemetry gaps longer than this, seconds. Default 3.0.
    pub max_gap_s: f64,
    /// Speeds below this count as stationary (no heading, no turn samples), m/s.
    /// Default 0.5.
    pub stationary_speed_mps: f64,
    /// Quantile of the demonstrated turn radii taken as the tightest turn (robust against
    /// a single noisy triple). Default 0.05.
    pub turn_radius_quantile: f64,
    /// Floor of the tightest turn radius, metres. Default 5.0.
    pub turn_radius_floor_m: f64,
    /// An obstacle is assumed able to turn at least this fast even if never seen turning,
    /// degrees per second. Default 5.0.
    pub turn_rate_floor_dps: f64,
    /// Number of most recent turn samples the radius quantile, histograms and tests use.
    /// Default 300.
    pub window_samples: usize,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self {
            velocity_window_s: 2.0,
            decision_interval_s: 1.0,
            heading_half_window_s: 0.25,
            max_gap_s: 3.0,
            stationary_speed_mps: 0.5,
            turn_radius_quantile: 0.05,
            turn_radius_floor_m: 5.0,
            turn_rate_floor_dps: 5.0,
            window_samples: 300,
        }
    }
}

/// One turn decision measured over a decision interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnSample {
    /// Interval index: the interval starts at `k * decision_interval_s`.
    pub k: i64,
    /// Signed turn rate, radians per second, counter-clockwise positive.
    pub omega_radps: f64,
    /// Radius of the circle through the interval's start, middle and end (infinite when
    /// straight), metres.
    pub radius_m: f64,
    /// Mean speed over the interval, m/s.
    pub speed_mps: f64,
}

/// Turn samples of one track, maintained incrementally.
#[derive(Debug, Clone, Default)]
pub struct TurnSampler {
    samples: Vec<TurnSample>,
    next_k: Option<i64>,
}

impl TurnSampler {
    /// Refreshes the samples after an observation was inserted at index `inserted` of the
    /// track. Samples whose window the insertion changed are recomputed; others are kept.
    /// Returns the number of samples removed plus the number (re)computed (0: unchanged).
    pub fn update(&mut self, track: &Track, inserted: usize, cfg: &EstimatorConfig) -> usize {
        let obs = track.observations();
        let (Some(first), Some(last)) = (obs.first(), obs.last()) else {
            return 0;
        };
        let dt = cfg.decision_interval_s;
        let k_start = (first.t_s / dt).ceil() as i64;
        // The insertion changes interpolated positions after the preceding observation:
        // samples whose interval ends after it are redone.
        let t_a = if inserted > 0 {
            obs[inserted - 1].t_s
        } else {
            f64::NEG_INFINITY
        };
        let k_bad = if t_a.is_finite() {
            (t_a / dt - 1.0).floor() as i64 + 1
        } else {
            i64::MIN
        };
        let before = self.samples.len();
        self.samples.retain(|s| s.k < k_bad && s.k >= k_start);
        let removed = before - self.samples.len();
        let mut k = self.next_k.map_or(k_start, |n| n.min(k_bad)).max(k_start);
        let mut n = 0;
        while k < i64::MAX && (k as f64 + 1.0) * dt <= last.t_s {
            if let Some(s) = sample_interval(track, k, cfg) {
                self.samples.push(s);
                n += 1;
                k += 1;
                continue;
            }
            // No interval that starts strictly inside a gap longer than `max_gap_s` has a
            // sample (its start has no position): jump over the gap in one step instead of
            // one interval at a time (a gap of years is hundreds of millions of intervals).
            let t0 = k as f64 * dt;
            let j = obs.partition_point(|o| o.t_s <= t0);
            let resume = if j > 0 && j < obs.len() && obs[j].t_s - obs[j - 1].t_s > cfg.max_gap_s {
                (obs[j].t_s / dt).ceil() as i64
            } else {
                k
            };
            k = resume.max(k.saturating_add(1));
        }
        self.next_k = Some(k);
        n + removed
    }

    /// All samples, oldest first.
    pub fn samples(&self) -> &[TurnSample] {
        &self.samples
    }

    /// The most recent `cfg.window_samples` samples.
    pub fn window(&self, cfg: &EstimatorConfig) -> &[TurnSample] {
        let n = self.samples.len();
        &self.samples[n.saturating_sub(cfg.window_samples)..]
    }
}

fn sample_interval(track: &Track, k: i64, cfg: &EstimatorConfig) -> Option<TurnSample> {
    let dt = cfg.decision_interval_s;
    let h = cfg.heading_half_window_s;
    let g = cfg.max_gap_s;
    let t0 = k as f64 * dt;
    let t1 = t0 + dt;
    let p0 = track.position_at(t0, g)?;
    let pm = track.position_at(t0 + 0.5 * dt, g)?;
    let p1 = track.position_at(t1, g)?;
    // Both chords lie inside the interval, so a sample measures this interval's turn only
    // (no leakage from the neighbouring decisions). The chords' mean headings are h/2 and
    // dt - h/2 into the interval: they are dt - h apart in time.
    let h0 = chord_heading(track, t0, t0 + h, cfg)?;
    let h1 = chord_heading(track, t1 - h, t1, cfg)?;
    let speed_mps = (dist(p0, pm) + dist(pm, p1)) / dt;
    Some(TurnSample {
        k,
        omega_radps: wrap_pi(h1 - h0) / (dt - h),
        radius_m: circumradius(p0, pm, p1),
        speed_mps,
    })
}

fn chord_heading(track: &Track, ta: f64, tb: f64, cfg: &EstimatorConfig) -> Option<f64> {
    let a = track.position_at(ta, cfg.max_gap_s)?;
    let b = track.position_at(tb, cfg.max_gap_s)?;
    if dist(a, b) < cfg.stationary_speed_mps * (tb - ta) {
        return None;
    }
    Some((b[1] - a[1]).atan2(b[0] - a[0]))
}

/// Wraps an angle to (-pi, pi] (the workspace's one implementation, in `geom`).
pub use geom::wrap_pi;

/// Radius of the circle through three points (infinite when they are collinear), metres.
pub fn circumradius(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    let ab = dist(a, b);
    let bc = dist(b, c);
    let ca = dist(c, a);
    let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    let area2 = cross.abs();
    if area2 <= 1e-12 * (ab * bc * ca).max(1e-300) {
        return f64::INFINITY;
    }
    ab * bc * ca / (2.0 * area2)
}

/// Current kinematic estimates of one obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Estimates {
    /// Time of the estimate (the newest observation), seconds.
    pub t_s: f64,
    /// Fitted position at `t_s`, ENU metres.
    pub position_m: [f64; 2],
    /// Fitted velocity at `t_s`, ENU m/s (zero when stationary).
    pub velocity_mps: [f64; 2],
    /// Speed, m/s (zero below the stationary threshold).
    pub speed_mps: f64,
    /// Compass heading, degrees: 0 = north, 90 = east (clockwise). `None` when stationary.
    pub heading_deg: Option<f64>,
    /// Tightest demonstrated turn radius (low quantile, floored), metres; `None` when no
    /// turn has been demonstrated.
    pub min_turn_radius_m: Option<f64>,
    /// Turn-rate capability used by the models at the current speed, degrees per second
    /// (0 when stationary): the demonstrated capability, at most the demonstrated lateral
    /// acceleration over the current speed (see [`TurnSummary::lat_accel_max_mps2`]).
    pub turn_rate_max_dps: f64,
    /// Most recent signed turn-rate sample, degrees per second, counter-clockwise (left)
    /// positive.
    pub turn_rate_dps: Option<f64>,
    /// Mean signed turn rate over the sample window, degrees per second.
    pub mean_turn_rate_dps: Option<f64>,
}

/// What the turn samples say about an obstacle's turning (recomputed only when the
/// samples change).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TurnSummary {
    /// Tightest demonstrated turn radius (low quantile, floored), metres; `None` when no
    /// turn has been demonstrated.
    pub min_turn_radius_m: Option<f64>,
    /// Turn-rate capability: mean sample speed over the tightest radius, divided by
    /// `1 - turn_radius_quantile` (see the source), at least the floor, rad/s.
    pub w_max_radps: f64,
    /// Lateral-acceleration capability: the `1 - turn_radius_quantile` quantile of the
    /// samples' `speed^2 / radius`, divided by `1 - turn_radius_quantile` like the turn
    /// rate, m/s^2; `None` with no samples. An obstacle that slows to turn (the judges'
    /// spline tours stop and reverse) demonstrates a tight radius at a walking pace; at its
    /// cruising speed the same turn would need many g, so the models turn at most
    /// `lat_accel_max_mps2 / speed` there (issue 10: a sphere cruising straight at 35 m/s
    /// was given 220 deg/s, its particles spun in place and the near-term map lost it).
    /// For an obstacle at constant speed both capabilities are the same.
    pub lat_accel_max_mps2: Option<f64>,
    /// Most recent turn rate, rad/s.
    pub last_omega_radps: Option<f64>,
    /// Mean turn rate over the window, rad/s.
    pub mean_omega_radps: Option<f64>,
}

impl TurnSummary {
    /// Summarizes a window of turn samples.
    pub fn from_window(window: &[TurnSample], cfg: &EstimatorConfig) -> Self {
        let floor = cfg.turn_rate_floor_dps.to_radians();
        if window.is_empty() {
            return Self {
                w_max_radps: floor,
                ..Self::default()
            };
        }
        let mut radii: Vec<f64> = window.iter().map(|s| s.radius_m).collect();
        radii.sort_by(f64::total_cmp);
        let idx = ((radii.len() - 1) as f64 * cfg.turn_radius_quantile).round() as usize;
        let r = radii[idx];
        let min_turn_radius_m = r.is_finite().then(|| r.max(cfg.turn_radius_floor_m));
        let n = window.len() as f64;
        let speed = window.iter().map(|s| s.speed_mps).sum::<f64>() / n;
        // The q-quantile of the radii is the (1 - q)-quantile of |omega|; under the uniform
        // turning the Random stage assumes, that is (1 - q) of the capability, so divide it
        // back out (otherwise the Random model is systematically too narrow).
        let w_max_radps = min_turn_radius_m.map_or(floor, |r| {
            (speed / r / (1.0 - cfg.turn_radius_quantile)).max(floor)
        });
        let mut accel: Vec<f64> = window
            .iter()
            .map(|s| {
                if s.radius_m.is_finite() {
                    s.speed_mps * s.speed_mps / s.radius_m.max(cfg.turn_radius_floor_m)
                } else {
                    0.0
                }
            })
            .collect();
        accel.sort_by(f64::total_cmp);
        let hi = ((accel.len() - 1) as f64 * (1.0 - cfg.turn_radius_quantile)).round() as usize;
        let lat_accel_max_mps2 = Some(accel[hi] / (1.0 - cfg.turn_radius_quantile));
        Self {
            min_turn_radius_m,
            w_max_radps,
            lat_accel_max_mps2,
            last_omega_radps: window.last().map(|s| s.omega_radps),
            mean_omega_radps: Some(window.iter().map(|s| s.omega_radps).sum::<f64>() / n),
        }
    }
}

/// Computes the estimates from the track and its turn summary. `None` for an empty track.
pub fn estimate(track: &Track, turns: &TurnSummary, cfg: &EstimatorConfig) -> Option<Estimates> {
    let last = *track.last()?;
    let obs = track.observations();
    let from = obs.partition_point(|o| o.t_s < last.t_s - cfg.velocity_window_s);
    let win = &obs[from..];
    let (position_m, mut velocity_mps) =
        fit_velocity(win, last.t_s).unwrap_or((last.p_m, [0.0, 0.0]));
    let mut speed_mps = velocity_mps[0].hypot(velocity_mps[1]);
    let mut heading_deg = None;
    if speed_mps < cfg.stationary_speed_mps {
        speed_mps = 0.0;
        velocity_mps = [0.0, 0.0];
    } else {
        heading_deg = Some(
            velocity_mps[0]
                .atan2(velocity_mps[1])
                .to_degrees()
                .rem_euclid(360.0),
        );
    }
    let TurnSummary {
        min_turn_radius_m,
        w_max_radps,
        lat_accel_max_mps2,
        last_omega_radps,
        mean_omega_radps,
    } = *turns;
    let turn_rate_dps = last_omega_radps.map(f64::to_degrees);
    let mean_turn_rate_dps = mean_omega_radps.map(f64::to_degrees);
    let turn_rate_max = if speed_mps > 0.0 {
        turn_capability(w_max_radps, lat_accel_max_mps2, speed_mps, cfg)
    } else {
        0.0
    };
    Some(Estimates {
        t_s: last.t_s,
        position_m,
        velocity_mps,
        speed_mps,
        heading_deg,
        min_turn_radius_m,
        turn_rate_max_dps: turn_rate_max.to_degrees(),
        turn_rate_dps,
        mean_turn_rate_dps,
    })
}

/// The turn rate an obstacle can fly at `speed_mps`: its demonstrated capability
/// `w_max_radps`, at most `lat_accel_max_mps2 / speed_mps`, at least the floor, rad/s.
pub fn turn_capability(
    w_max_radps: f64,
    lat_accel_max_mps2: Option<f64>,
    speed_mps: f64,
    cfg: &EstimatorConfig,
) -> f64 {
    let floor = cfg.turn_rate_floor_dps.to_radians();
    let by_accel = match lat_accel_max_mps2 {
        Some(a) if speed_mps > 0.0 => a / speed_mps,
        _ => f64::INFINITY,
    };
    w_max_radps.min(by_accel).max(floor)
}

/// Least-squares fit of position against time over `win`, evaluated at `t_ref`:
/// a quadratic ("a curve through the last several points") when there are at least 5
/// observations spanning 0.5 s, else a line; `None` with fewer than 2 observations.
pub(crate) fn fit_velocity(
    win: &[crate::track::Observation],
    t_ref: f64,
) -> Option<([f64; 2], [f64; 2])> {
    if win.len() < 2 {
        return None;
    }
    let span = win[win.len() - 1].t_s - win[0].t_s;
    let order = if win.len() >= 5 && span >= 0.5 { 3 } else { 2 };
    let mut ata = Matrix3::<f64>::zeros();
    let mut atx = Vector3::<f64>::zeros();
    let mut aty = Vector3::<f64>::zeros();
    for o in win {
        let tau = o.t_s - t_ref;
        let row = Vector3::new(1.0, tau, if order == 3 { tau * tau } else { 0.0 });
        ata += row * row.transpose();
        atx += row * o.p_m[0];
        aty += row * o.p_m[1];
    }
    if order == 2 {
        ata[(2, 2)] = 1.0;
    }
    let inv = ata.try_inverse()?;
    let cx = inv * atx;
    let cy = inv * aty;
    Some(([cx[0], cy[0]], [cx[1], cy[1]]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::Observation;

    #[test]
    fn circumradius_of_a_right_triangle_is_half_its_hypotenuse() {
        // (0,0), (3,0), (0,4): hypotenuse 5 -> radius 2.5.
        assert!((circumradius([0.0, 0.0], [3.0, 0.0], [0.0, 4.0]) - 2.5).abs() < 1e-12);
        assert!(circumradius([0.0, 0.0], [1.0, 1.0], [2.0, 2.0]).is_infinite());
    }

    #[test]
    fn a_circle_gives_its_turn_rate_and_radius() {
        // 10 m/s on a 100 m circle counter-clockwise: omega = 0.1 rad/s = 5.73 deg/s.
        let cfg = EstimatorConfig::default();
        let mut tr = Track::default();
        let mut ts = TurnSampler::default();
        for i in 0..=100 {
            let t = f64::from(i) * 0.1;
            let a = 0.1 * t;
            let o = Observation {
                t_s: t,
                p_m: [100.0 * a.cos(), 100.0 * a.sin()],
                alt_m: 0.0,
                radius_m: 5.0,
            };
            let (_, idx) = tr.insert(o, 50.0, 0.0);
            ts.update(&tr, idx.unwrap(), &cfg);
        }
        // Complete intervals: k = 0 .. 9 ((k+1) <= 10).
        assert_eq!(ts.samples().len(), 10);
        for s in ts.samples() {
            // 2%: chord ends at 0.25 s are interpolated between 10 Hz points, slightly
            // inside the circle, which tilts the chords a little.
            assert!((s.omega_radps - 0.1).abs() < 2e-3, "{s:?}");
            assert!((s.radius_m - 100.0).abs() < 0.5, "{s:?}");
        }
        let e = estimate(&tr, &TurnSummary::from_window(ts.window(&cfg), &cfg), &cfg).unwrap();
        assert!((e.speed_mps - 10.0).abs() < 0.05);
        // At t = 10 the angle is 1 rad; velocity direction (math) 1 + pi/2 rad.
        let math = 1.0 + std::f64::consts::FRAC_PI_2;
        let compass = (90.0 - math.to_degrees()).rem_euclid(360.0);
        assert!((e.heading_deg.unwrap() - compass).abs() < 0.5);
        assert!((e.min_turn_radius_m.unwrap() - 100.0).abs() < 0.5);
    }

    #[test]
    fn out_of_order_insertions_give_the_same_samples_as_in_order() {
        let cfg = EstimatorConfig::default();
        let pts: Vec<Observation> = (0..80)
            .map(|i| {
                let t = f64::from(i) * 0.1;
                Observation {
                    t_s: t,
                    p_m: [10.0 * t, (t * 0.7).sin() * 8.0],
                    alt_m: 0.0,
                    radius_m: 5.0,
                }
            })
            .collect();
        let run = |order: &[usize]| {
            let mut tr = Track::default();
            let mut ts = TurnSampler::default();
            for &i in order {
                if let (_, Some(idx)) = tr.insert(pts[i], 50.0, 0.0) {
                    ts.update(&tr, idx, &cfg);
                }
            }
            ts.samples().to_vec()
        };
        let in_order: Vec<usize> = (0..80).collect();
        let mut shuffled = in_order.clone();
        // Swap neighbours pairwise: every second observation arrives late.
        for c in shuffled.chunks_mut(2) {
            c.reverse();
        }
        assert_eq!(run(&in_order), run(&shuffled));
    }

    #[test]
    fn a_gap_of_years_is_skipped_with_the_samples_either_side_kept() {
        // 10 s of a straight track, ~11.7 years of silence, 10 s more. Walking the gap one
        // 1 s interval at a time took minutes (a request stalled on it); the samples are
        // the two stretches' own.
        let cfg = EstimatorConfig::default();
        let stretch = |t0: f64| -> Vec<Observation> {
            (0..=100)
                .map(|i| {
                    let t = t0 + f64::from(i) * 0.1;
                    Observation {
                        t_s: t,
                        p_m: [10.0 * (t - t0), 0.0],
                        alt_m: 0.0,
                        radius_m: 5.0,
                    }
                })
                .collect()
        };
        let run = |obs: &[Observation]| {
            let mut tr = Track::default();
            let mut ts = TurnSampler::default();
            for o in obs {
                if let (_, Some(idx)) = tr.insert(*o, 1e9, 0.0) {
                    ts.update(&tr, idx, &cfg);
                }
            }
            ts.samples().to_vec()
        };
        let far = 368_445_877.0;
        let mut both = stretch(0.0);
        both.extend(stretch(far));
        let samples = run(&both);
        let (a, b) = (run(&stretch(0.0)), run(&stretch(far)));
        assert_eq!(a.len(), 10);
        assert_eq!(b.len(), 10);
        let mut expected = a;
        expected.extend(b);
        assert_eq!(samples, expected);
    }
}
