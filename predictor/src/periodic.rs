//! Periodic tours: an obstacle that retraces its own path is predicted from its own earlier
//! lap (issue 10, "prediction that exploits how obstacles really move"; seed 002's memory
//! stage taken to whole slices of past behaviour).
//!
//! The judges' server flies each moving sphere round a closed periodic cubic spline at a
//! fixed period, so its position at `t + L` is its position at `t`. The last
//! [`PeriodicConfig::window_s`] seconds of the track (its *signature*, sampled every
//! [`PeriodicConfig::step_s`]) are compared with every earlier stretch of the track at least
//! [`PeriodicConfig::min_period_s`] older: a lag `L` whose stretch matches the signature with
//! an RMS distance of at most [`PeriodicConfig::max_rms_m`] (and whose first sample is
//! within that distance, a cheap filter that keeps the search linear in the track's length)
//! is a lap. The smallest such lag wins (the most recent lap; multiples of the period also
//! match), refined to a tenth of the step. A straight flyer never matches (its positions
//! never repeat); a random turner matches only by a coincidence the window makes unlikely.
//!
//! The prediction `s` seconds ahead is the track at `t0 + s - k L` (the smallest `k` that
//! lands inside the observed lap), spread by a timing jitter and a position noise that grow
//! with `s` ([`Lap::sigma_m`]). The search is a pure function of the track and its newest
//! time, so a predictor fed batch by batch and one rebuilt from the same rows agree.
//!
//! # Units
//! ENU metres, seconds.

use crate::track::Track;
use geom::dist;

/// Lap-search parameters, with documented defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PeriodicConfig {
    /// Length of the signature, seconds. Default 10.
    pub window_s: f64,
    /// Spacing of the signature's samples, seconds. Default 1.
    pub step_s: f64,
    /// Shortest lap considered, seconds. Default 20.
    pub min_period_s: f64,
    /// Largest RMS distance between the signature and a match, metres. Default 6.
    pub max_rms_m: f64,
    /// Largest gap between observations to interpolate across, seconds. Default 5.
    pub max_gap_s: f64,
}

impl Default for PeriodicConfig {
    fn default() -> Self {
        Self {
            window_s: 10.0,
            step_s: 1.0,
            min_period_s: 20.0,
            max_rms_m: 6.0,
            max_gap_s: 5.0,
        }
    }
}

/// A recognized lap.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Lap {
    /// The period, seconds.
    pub period_s: f64,
    /// RMS distance between the signature and the earlier lap, metres.
    pub rms_m: f64,
    /// The newest observation time the lap was found at, seconds.
    pub t0_s: f64,
}

impl Lap {
    /// The time on the observed track whose position predicts `t_s` (at most `t0_s`).
    pub fn source_time(&self, t_s: f64) -> f64 {
        let s = t_s - self.t0_s;
        if s <= 0.0 {
            return t_s;
        }
        let k = (s / self.period_s).ceil();
        t_s - k * self.period_s
    }

    /// One-sigma position spread (per axis) `s` seconds ahead, metres: the match's RMS
    /// plus 1 m, growing by 5 cm per second ahead.
    pub fn sigma_m(&self, s: f64) -> f64 {
        self.rms_m + 1.0 + 0.05 * s.max(0.0)
    }

    /// One-sigma timing jitter `s` seconds ahead, seconds (the period is known to about
    /// a tenth of the signature step; the error adds up lap after lap).
    pub fn jitter_s(&self, s: f64) -> f64 {
        0.1 + 0.1 * (s.max(0.0) / self.period_s).ceil()
    }

    /// The predicted position `s` seconds after `t0_s` before spreading, from `track`;
    /// `None` where the track has a gap.
    pub fn position(&self, track: &Track, s: f64, max_gap_s: f64) -> Option<[f64; 2]> {
        track.position_at(self.source_time(self.t0_s + s), max_gap_s)
    }
}

fn rms(track: &Track, sig: &[[f64; 2]], lag: f64, t0: f64, cfg: &PeriodicConfig) -> Option<f64> {
    let mut sum = 0.0;
    for (j, q) in sig.iter().enumerate() {
        let p = track.position_at(t0 - lag - j as f64 * cfg.step_s, cfg.max_gap_s)?;
        let d = dist(p, *q);
        sum += d * d;
    }
    Some((sum / sig.len() as f64).sqrt())
}

/// Searches `track` for a lap ending at its newest observation (see the module docs).
pub fn find_lap(track: &Track, cfg: &PeriodicConfig) -> Option<Lap> {
    let obs = track.observations();
    let (first, last) = (obs.first()?.t_s, obs.last()?.t_s);
    let t0 = last;
    let n_sig = (cfg.window_s / cfg.step_s).floor() as usize + 1;
    let span_sig = (n_sig - 1) as f64 * cfg.step_s;
    if t0 - first < cfg.min_period_s + span_sig {
        return None;
    }
    let sig: Vec<[f64; 2]> = (0..n_sig)
        .map(|j| track.position_at(t0 - j as f64 * cfg.step_s, cfg.max_gap_s))
        .collect::<Option<_>>()?;
    // Candidate lags: observations near the newest position, old enough, in runs; the best
    // of each run (closest to the newest position) is scored on the whole signature.
    let latest = t0 - cfg.min_period_s;
    let earliest = first + span_sig;
    let mut best: Option<(f64, f64)> = None;
    let mut run: Option<(f64, f64)> = None;
    let flush = |run: &mut Option<(f64, f64)>, best: &mut Option<(f64, f64)>| {
        if let Some((_, tau)) = run.take()
            && best.is_none()
        {
            // Refine the lag around the observation to a tenth of the step.
            let mut lag = t0 - tau;
            let mut e = rms(track, &sig, lag, t0, cfg).unwrap_or(f64::INFINITY);
            let mut h = cfg.step_s * 0.5;
            while h >= cfg.step_s * 0.05 {
                for cand in [lag - h, lag + h] {
                    if cand < cfg.min_period_s || t0 - cand < earliest {
                        continue;
                    }
                    if let Some(ec) = rms(track, &sig, cand, t0, cfg)
                        && ec < e
                    {
                        (lag, e) = (cand, ec);
                    }
                }
                h *= 0.5;
            }
            if e <= cfg.max_rms_m {
                *best = Some((lag, e));
            }
        }
    };
    // Newest first: the first run that matches is the most recent lap.
    for o in obs.iter().rev() {
        if o.t_s > latest {
            continue;
        }
        if o.t_s < earliest {
            break;
        }
        let d = dist(o.p_m, sig[0]);
        if d <= 3.0 * cfg.max_rms_m {
            match run {
                Some((dr, _)) if d >= dr => {}
                _ => run = Some((d, o.t_s)),
            }
        } else {
            flush(&mut run, &mut best);
            if best.is_some() {
                break;
            }
        }
    }
    flush(&mut run, &mut best);
    best.map(|(period_s, rms_m)| Lap {
        period_s,
        rms_m,
        t0_s: t0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::Observation;

    fn track(f: impl Fn(f64) -> [f64; 2], secs: f64, hz: f64) -> Track {
        let mut t = Track::default();
        let n = (secs * hz) as usize;
        for k in 0..=n {
            let ts = k as f64 / hz;
            t.insert(
                Observation {
                    t_s: ts,
                    p_m: f(ts),
                    alt_m: 100.0,
                    radius_m: 10.0,
                },
                100.0,
                2.0,
            );
        }
        t
    }

    #[test]
    fn a_circuit_is_recognized_with_its_period() {
        // A 200 m radius circle at 10 m/s: period 2 pi 200 / 10 = 125.66 s.
        let w = 10.0 / 200.0;
        let t = track(
            |s| [200.0 * (w * s).cos(), 200.0 * (w * s).sin()],
            300.0,
            5.0,
        );
        let lap = find_lap(&t, &PeriodicConfig::default()).expect("a lap");
        assert!((lap.period_s - 125.66).abs() < 0.2, "{lap:?}");
        assert!(lap.rms_m < 1.0, "{lap:?}");
        // Predicted 30 s ahead from the earlier lap: within a metre of the truth.
        let p = lap.position(&t, 30.0, 5.0).unwrap();
        let truth = [200.0 * (w * 330.0).cos(), 200.0 * (w * 330.0).sin()];
        assert!(dist(p, truth) < 1.0, "{p:?} {truth:?}");
    }

    #[test]
    fn a_straight_flyer_and_a_short_track_have_no_lap() {
        let straight = track(|s| [10.0 * s, 3.0 * s], 300.0, 5.0);
        assert_eq!(find_lap(&straight, &PeriodicConfig::default()), None);
        let w = 10.0 / 200.0;
        let short = track(
            |s| [200.0 * (w * s).cos(), 200.0 * (w * s).sin()],
            100.0,
            5.0,
        );
        assert_eq!(find_lap(&short, &PeriodicConfig::default()), None);
    }
}
