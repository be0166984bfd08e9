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
//! A turner that circles for a while matches its last circle within the window without
//! flying a tour, so a repeat must also hold over the last [`PeriodicConfig::validate_s`]
//! before it (as much of it as has a lap before it): the track there must match itself one
//! period earlier within [`PeriodicConfig::max_rms_m`] RMS.
//!
//! The prediction `s` seconds ahead is the track at `t0 + s - k L` (the smallest `k` that
//! lands inside the observed lap), spread across by half that validated RMS (the distance
//! between two passes each carrying the observation noise is about twice the noise of one)
//! and along by a timing jitter that grows lap by lap ([`Lap::sigma_m`], [`Lap::jitter_s`]).
//! The search is a pure function of the track and its newest time, so a predictor fed batch
//! by batch and one rebuilt from the same rows agree.
//!
//! Mirrored laps ([`LapKind::Mirror`]): a tour through two waypoints is the same periodic
//! spline between two points, an out-and-back on a line, slowing to a stop at each end and
//! symmetric in time about it, so after a turn-back the obstacle retraces what it flew
//! before the turn-back, backward. A whole lap of such a tour takes until it is back where
//! it was first seen (twice the leg); the mirror is recognized as soon as the signature has
//! flown [`PeriodicConfig::window_s`] past the turn-back (on a track younger than
//! [`PeriodicConfig::fresh_mirror_max_track_s`], the newest
//! [`PeriodicConfig::mirror_window_s`] of it while the turn-back lies within the last
//! half-window): when no lap matches, the signature
//! is compared with every earlier stretch flown forward from its start (`P(t0 - L + j)`
//! against `P(t0 - j)`), and the prediction `s` seconds ahead is the track at `t0 - L - s`,
//! until that runs off the start of the track (the prediction is then the obstacle's own
//! model, manoeuvre replay when it has the history). A mirror needs the signature to match
//! within [`MIRROR_MAX_RMS`] (tighter than a lap) and to span at least [`MIRROR_MIN_CHORD`]
//! times [`PeriodicConfig::max_rms_m`] end to end, so a slow or hovering obstacle, which
//! matches itself backward trivially, is not taken for one; and the whole flight since the
//! turn-back, not only the signature, must retrace the flight before it, on a straight
//! line, within [`MIRROR_MAX_RMS`] (an obstacle that turns round in a loop or a zigzag and
//! flies back near its own path for a while does not, at the turn). A hairpin of a longer
//! tour can pass all of this near its tip and leave its own path further on, so a mirror's
//! spread grows faster than a lap's ([`MIRROR_SPREAD_MPS`]).
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
    /// How far back a repeat is checked beyond its signature, seconds: the track over the
    /// last `validate_s` (as much of it as has a lap before it) must match itself one period
    /// earlier within [`PeriodicConfig::max_rms_m`] RMS, and that RMS sets the lap's spread
    /// ([`Lap::sigma_m`]). Default 60.
    #[cfg_attr(feature = "serde", serde(default = "default_validate_s"))]
    pub validate_s: f64,
    /// The shorter signature a fresh turn-back is mirrored on, seconds: when neither a
    /// repeat nor a mirror matches the whole [`PeriodicConfig::window_s`] signature, a
    /// mirror whose turn-back lies within the last `window_s / 2` is looked for with only
    /// the newest `mirror_window_s` of it (lags from twice this to twice the half-window),
    /// under the same tests, so an out-and-back is mirrored this long after its turn-back
    /// rather than a whole window later. At or above `window_s`: off. Default 4.
    #[cfg_attr(feature = "serde", serde(default = "default_mirror_window_s"))]
    pub mirror_window_s: f64,
    /// The longest track (newest minus first observation time), seconds, whose turn-backs
    /// the shorter signature ([`PeriodicConfig::mirror_window_s`]) is tried on. A young
    /// track holds no validated repeat of a longer lap yet, and manoeuvre replay has seen
    /// few or none of its turns, so its fresh turn-back is otherwise predicted to
    /// turn on round; an older one's turn-backs are predicted by its repeat, its
    /// whole-window mirror or its replay, which have seen them. Default 60 (Webster Field
    /// with spline spheres, seed 204, whose waypoint 7 a 20.8 s shuttle sweeps: with no
    /// limit it never captured that waypoint, 8 of 14 in all, and with 60 s all 14; at
    /// 30 s, mixed seed 464's sphere, tracked for longer than that at its fresh
    /// turn-back, was not mirrored and hit the aircraft).
    #[cfg_attr(feature = "serde", serde(default = "default_fresh_mirror_max_track_s"))]
    pub fresh_mirror_max_track_s: f64,
}

#[cfg(feature = "serde")]
fn default_fresh_mirror_max_track_s() -> f64 {
    PeriodicConfig::default().fresh_mirror_max_track_s
}

#[cfg(feature = "serde")]
fn default_mirror_window_s() -> f64 {
    PeriodicConfig::default().mirror_window_s
}

#[cfg(feature = "serde")]
fn default_validate_s() -> f64 {
    PeriodicConfig::default().validate_s
}

impl Default for PeriodicConfig {
    fn default() -> Self {
        Self {
            window_s: 10.0,
            step_s: 1.0,
            min_period_s: 20.0,
            max_rms_m: 6.0,
            max_gap_s: 5.0,
            validate_s: 60.0,
            mirror_window_s: 4.0,
            fresh_mirror_max_track_s: 60.0,
        }
    }
}

/// The signature's span, end to end, that a mirrored lap needs, in units of
/// [`PeriodicConfig::max_rms_m`] (18 m over the default 10 s window: 1.8 m/s on average;
/// over a fresh turn-back's 4 s, 4.5 m/s).
pub const MIRROR_MIN_CHORD: f64 = 3.0;

/// The RMS distance the whole flight since a mirror's turn-back may have from the flight
/// before it, and the flight around the turn-back from one straight line, in units of
/// [`PeriodicConfig::max_rms_m`] (3 m by default; 1 m of noise per axis on both positions
/// makes about 2 m between them).
pub const MIRROR_MAX_RMS: f64 = 0.5;

/// How fast a mirror's spread grows, m/s per axis. A hairpin of a tour through more than
/// two waypoints can retrace itself on a line near its tip, within every test above, and
/// then leave its own path: in `sim/tests/mirror.rs` (20 Webster Field scenarios) such
/// mirrors were 18 of 3239 mirrored seconds and 6-20 m off 10 s ahead, where true
/// out-and-backs were 1 m off at the median. At 0.5 m/s the 95% disc (2.45 sigma) has a
/// 20-25 m radius at +10 s, still a sixth of manoeuvre replay's; at 0.05 m/s (a repeat's
/// growth then), 16 of the 36 hairpin predictions there fell outside it.
pub const MIRROR_SPREAD_MPS: f64 = 0.5;

/// The least one-sigma spread per axis of a repeated lap, metres ([`Lap::sigma_m`]): a
/// tour observed without noise still matches only to the precision of its refined period.
pub const LAP_MIN_SIGMA_M: f64 = 0.5;

/// One-sigma timing error of a refined period, seconds ([`Lap::jitter_s`]): the lag's last
/// refinement step is a sixteenth of [`PeriodicConfig::step_s`] (1/16 s by default), so it
/// rounds within +-1/32 s (a uniform error of sigma 0.018 s), and the noise moves the best
/// lag a little more. 0.05 s until 2026-12-05 (half a tenth of the step, the rounding's
/// bound rather than its sigma): with 1 m of noise at 2 Hz that drew a spread along the
/// track wider than the error, and the prediction report's 95% region of a spline tour
/// covered 98-99%; at 0.025 s it covers 96-97% (README, "Prediction report").
pub const LAP_JITTER_S: f64 = 0.025;

/// How a lap maps the future onto the observed track.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum LapKind {
    /// The tour repeats: the position at `t + period` is the position at `t`.
    #[default]
    Repeat,
    /// The tour retraces itself backward after a turn-back (see the module docs): the
    /// position at `t0 + s` is the position at `t0 - period - s`.
    Mirror,
}

/// A recognized lap.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Lap {
    /// The period, seconds (for a mirror, the time between the newest observation and the
    /// earlier time at the same place: twice the time since the turn-back).
    pub period_s: f64,
    /// RMS distance between the track and the earlier lap, metres: for a repeat over the
    /// validated stretch ([`PeriodicConfig::validate_s`]), for a mirror over the signature.
    pub rms_m: f64,
    /// The newest observation time the lap was found at, seconds.
    pub t0_s: f64,
    /// Repeated or mirrored.
    #[cfg_attr(feature = "serde", serde(default))]
    pub kind: LapKind,
}

impl Lap {
    /// The time on the observed track whose position predicts `t_s` (at most `t0_s`; for a
    /// mirror it may precede the track's first observation, which then predicts nothing).
    pub fn source_time(&self, t_s: f64) -> f64 {
        let s = t_s - self.t0_s;
        if s <= 0.0 {
            return t_s;
        }
        match self.kind {
            LapKind::Repeat => t_s - (s / self.period_s).ceil() * self.period_s,
            LapKind::Mirror => self.t0_s - self.period_s - s,
        }
    }

    /// One-sigma position spread (per axis) `s` seconds ahead, metres. A repeat: half the
    /// match's RMS, at least [`LAP_MIN_SIGMA_M`], not growing (the RMS distance between two
    /// passes, each with noise of sigma per axis, is about `2 sigma`; across the track the
    /// prediction is one observed pass, so its error does not grow with the time ahead,
    /// and along it the timing jitter grows). A mirror: the match's RMS plus 1 m, growing by
    /// [`MIRROR_SPREAD_MPS`].
    pub fn sigma_m(&self, s: f64) -> f64 {
        match self.kind {
            LapKind::Repeat => (0.5 * self.rms_m).max(LAP_MIN_SIGMA_M),
            LapKind::Mirror => self.rms_m + 1.0 + MIRROR_SPREAD_MPS * s.max(0.0),
        }
    }

    /// One-sigma timing jitter `s` seconds ahead, seconds: [`LAP_JITTER_S`] plus as much per
    /// lap back the prediction reaches, since the error of the period adds up lap after lap.
    pub fn jitter_s(&self, s: f64) -> f64 {
        LAP_JITTER_S + LAP_JITTER_S * (s.max(0.0) / self.period_s).ceil()
    }

    /// The predicted position `s` seconds after `t0_s` before spreading, from `track`;
    /// `None` where the track has a gap.
    pub fn position(&self, track: &Track, s: f64, max_gap_s: f64) -> Option<[f64; 2]> {
        track.position_at(self.source_time(self.t0_s + s), max_gap_s)
    }

    /// What a prediction `s` seconds after `t0_s` spreads from: the lap's position there,
    /// its velocity (the positions half a second either side, the base itself where one of
    /// them falls in a gap), and the spread and timing jitter at `s`; `None` where the base
    /// falls in a gap of more than `max_gap_s` or a mirror has run off the track's start.
    /// The predictor's samples and the risk map's particles are both drawn from it.
    pub fn at(&self, track: &Track, s: f64, max_gap_s: f64) -> Option<LapPoint> {
        let base = self.position(track, s, max_gap_s)?;
        let ahead = self.position(track, s + 0.5, max_gap_s).unwrap_or(base);
        let behind = self.position(track, s - 0.5, max_gap_s).unwrap_or(base);
        Some(LapPoint {
            base,
            velocity: [ahead[0] - behind[0], ahead[1] - behind[1]],
            sigma_m: self.sigma_m(s),
            jitter_s: self.jitter_s(s),
        })
    }
}

/// A lap's prediction at one time ahead, before spreading ([`Lap::at`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LapPoint {
    /// The position the lap predicts, metres ENU.
    pub base: [f64; 2],
    /// The lap's velocity there, m/s.
    pub velocity: [f64; 2],
    /// One-sigma position spread per axis, metres ([`Lap::sigma_m`]).
    pub sigma_m: f64,
    /// One-sigma timing jitter, seconds ([`Lap::jitter_s`]).
    pub jitter_s: f64,
}

impl LapPoint {
    /// One spread position from three standard normal deviates: `z[0]` shifts it along the
    /// velocity by the timing jitter, `z[1]` and `z[2]` across each axis by the spread.
    pub fn particle(&self, z: [f64; 3]) -> [f64; 2] {
        let (v, jit, sig) = (self.velocity, self.jitter_s, self.sigma_m);
        [
            self.base[0] + v[0] * z[0] * jit + z[1] * sig,
            self.base[1] + v[1] * z[0] * jit + z[2] * sig,
        ]
    }
}

/// RMS distance between the signature (`sig[j]` at `t0 - j step`) and the stretch at lag
/// `lag`: flown the same way (`t0 - lag - j step`) for a repeat, backward from its start
/// (`t0 - lag + j step`) for a mirror.
fn rms(
    track: &Track,
    sig: &[[f64; 2]],
    lag: f64,
    t0: f64,
    cfg: &PeriodicConfig,
    kind: LapKind,
) -> Option<f64> {
    let dir = match kind {
        LapKind::Repeat => -1.0,
        LapKind::Mirror => 1.0,
    };
    let mut sum = 0.0;
    for (j, q) in sig.iter().enumerate() {
        let p = track.position_at(t0 - lag + dir * j as f64 * cfg.step_s, cfg.max_gap_s)?;
        let d = dist(p, *q);
        sum += d * d;
    }
    Some((sum / sig.len() as f64).sqrt())
}

/// A repeat checked over the last [`PeriodicConfig::validate_s`] of the track (at least the
/// signature; no further back than a whole lap after the track's first observation): the
/// RMS distance between the track and itself one period earlier, at every signature step,
/// must stay within [`PeriodicConfig::max_rms_m`], and becomes the lap's `rms_m`. The
/// signature alone can match an obstacle that circles for a while without repeating (a
/// turner with a bias): its circles drift apart over a longer stretch. It is also the
/// better estimate of a true tour's spread: the lag was refined to fit the signature best,
/// which the signature's own RMS therefore understates.
fn validated(track: &Track, lap: Lap, first: f64, cfg: &PeriodicConfig) -> Option<Lap> {
    let span = cfg.validate_s.min(lap.t0_s - lap.period_s - first).max(0.0);
    let n = (span / cfg.step_s).floor() as usize;
    let (mut sum, mut k) = (0.0, 0usize);
    for j in 0..=n {
        let t = lap.t0_s - j as f64 * cfg.step_s;
        if let (Some(p), Some(q)) = (
            track.position_at(t, cfg.max_gap_s),
            track.position_at(t - lap.period_s, cfg.max_gap_s),
        ) {
            let d = dist(p, q);
            sum += d * d;
            k += 1;
        }
    }
    let rms_m = if k > 0 {
        (sum / k as f64).sqrt()
    } else {
        lap.rms_m
    };
    (rms_m <= cfg.max_rms_m).then_some(Lap { rms_m, ..lap })
}

/// Whether the flight around a mirror's turn-back (`t0 - lag / 2`) is an out-and-back on a
/// line: positions the same time before and after the turn-back, at every step from it to
/// the newest observation, within [`MIRROR_MAX_RMS`] RMS of each other (the signature alone
/// checks only the newest [`PeriodicConfig::window_s`]: an obstacle that turns round in a
/// loop or a zigzag and then flies back near its own path for a while fails here, at the
/// turn), and all of them within the same RMS of one straight line (a two-waypoint tour is
/// a line; a narrow loop through three waypoints retraces itself only roughly and drifts
/// apart from its own path further on).
fn out_and_back_on_a_line(track: &Track, t0: f64, lag: f64, cfg: &PeriodicConfig) -> bool {
    let (tm, half) = (t0 - 0.5 * lag, 0.5 * lag);
    let n = (half / cfg.step_s).floor() as usize;
    let limit = MIRROR_MAX_RMS * cfg.max_rms_m;
    let mut pts = Vec::with_capacity(2 * n + 2);
    let mut sum = 0.0;
    for k in 0..=n {
        let d = k as f64 * cfg.step_s;
        let (Some(a), Some(b)) = (
            track.position_at(tm - d, cfg.max_gap_s),
            track.position_at(tm + d, cfg.max_gap_s),
        ) else {
            return false;
        };
        sum += dist(a, b).powi(2);
        pts.extend([a, b]);
    }
    if (sum / (n + 1) as f64).sqrt() > limit {
        return false;
    }
    // The spread across the principal axis: the smaller eigenvalue of the covariance.
    let m = pts.len() as f64;
    let c = pts
        .iter()
        .fold([0.0; 2], |c, p| [c[0] + p[0] / m, c[1] + p[1] / m]);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in &pts {
        let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
        sxx += dx * dx / m;
        syy += dy * dy / m;
        sxy += dx * dy / m;
    }
    let across = 0.5 * (sxx + syy) - (0.25 * (sxx - syy).powi(2) + sxy * sxy).sqrt();
    across.max(0.0).sqrt() <= limit
}

/// Searches `track` for a lap ending at its newest observation (see the module docs): a
/// repeat if one matches, else a mirror.
pub fn find_lap(track: &Track, cfg: &PeriodicConfig) -> Option<Lap> {
    let obs = track.observations();
    let (first, last) = (obs.first()?.t_s, obs.last()?.t_s);
    let t0 = last;
    let n_sig = (cfg.window_s / cfg.step_s).floor() as usize + 1;
    let span_sig = (n_sig - 1) as f64 * cfg.step_s;
    // The shortest mirror: the matched stretch ends where the signature starts.
    let min_mirror_s = 2.0 * span_sig;
    // A fresh turn-back's shorter signature (`mirror_window_s`; the whole one at most), and
    // the shortest mirror on it.
    let n_short = ((cfg.mirror_window_s / cfg.step_s).floor() as usize + 1).clamp(2, n_sig);
    let shortest = 2.0 * (n_short - 1) as f64 * cfg.step_s;
    if t0 - first < (cfg.min_period_s + span_sig).min(shortest) {
        return None;
    }
    let signature = |n: usize| -> Option<Vec<[f64; 2]>> {
        (0..n)
            .map(|j| track.position_at(t0 - j as f64 * cfg.step_s, cfg.max_gap_s))
            .collect()
    };
    let found = |sig: &[[f64; 2]], kind, min_lag, max_lag| {
        search(track, sig, t0, cfg, kind, min_lag, max_lag).map(|(period_s, rms_m)| Lap {
            period_s,
            rms_m,
            t0_s: t0,
            kind,
        })
    };
    let mirror = |sig: &[[f64; 2]], min_lag: f64, max_lag: f64| {
        (dist(sig[0], sig[sig.len() - 1]) >= MIRROR_MIN_CHORD * cfg.max_rms_m)
            .then(|| found(sig, LapKind::Mirror, min_lag, max_lag))
            .flatten()
    };
    if let Some(sig) = signature(n_sig) {
        let lap = found(
            &sig,
            LapKind::Repeat,
            cfg.min_period_s,
            t0 - first - span_sig,
        )
        .and_then(|lap| validated(track, lap, first, cfg))
        .or_else(|| mirror(&sig, min_mirror_s, t0 - first));
        if lap.is_some() {
            return lap;
        }
    }
    // A young track's turn-back within the last half-window: mirrored on the newest
    // `mirror_window_s`.
    if n_short < n_sig && t0 - first < cfg.fresh_mirror_max_track_s {
        let sig = signature(n_short)?;
        return mirror(&sig, shortest, min_mirror_s.min(t0 - first));
    }
    None
}

/// The smallest lag in `[min_lag, max_lag]` whose stretch matches the signature `sig` within
/// [`PeriodicConfig::max_rms_m`], with its RMS distance. Candidates are the observations
/// near the newest position, in runs; the best of each run (closest to the newest position)
/// is refined to a tenth of the step, starting a whole step either side of it (where the
/// tour is slow, noise can make the closest observation one more than a second from the
/// lag), and scored on the whole signature; newest first, so
/// the first run that matches is the most recent lap.
fn search(
    track: &Track,
    sig: &[[f64; 2]],
    t0: f64,
    cfg: &PeriodicConfig,
    kind: LapKind,
    min_lag: f64,
    max_lag: f64,
) -> Option<(f64, f64)> {
    if max_lag < min_lag {
        return None;
    }
    let mut best: Option<(f64, f64)> = None;
    let mut run: Option<(f64, f64)> = None;
    let flush = |run: &mut Option<(f64, f64)>, best: &mut Option<(f64, f64)>| {
        if let Some((_, tau)) = run.take()
            && best.is_none()
        {
            let mut lag = t0 - tau;
            let mut e = rms(track, sig, lag, t0, cfg, kind).unwrap_or(f64::INFINITY);
            let mut h = cfg.step_s;
            while h >= cfg.step_s * 0.05 {
                for cand in [lag - h, lag + h] {
                    if cand < min_lag || cand > max_lag {
                        continue;
                    }
                    if let Some(ec) = rms(track, sig, cand, t0, cfg, kind)
                        && ec < e
                    {
                        (lag, e) = (cand, ec);
                    }
                }
                h *= 0.5;
            }
            let ok = match kind {
                LapKind::Repeat => e <= cfg.max_rms_m,
                LapKind::Mirror => {
                    e <= MIRROR_MAX_RMS * cfg.max_rms_m
                        && out_and_back_on_a_line(track, t0, lag, cfg)
                }
            };
            if ok {
                *best = Some((lag, e));
            }
        }
    };
    for o in track.observations().iter().rev() {
        if o.t_s > t0 - min_lag {
            continue;
        }
        if o.t_s < t0 - max_lag {
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
    best
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

    /// An out-and-back on a line (a two-waypoint tour): 300 m either side of the origin
    /// every 120 s, turning back at t = 40 s (and at 100 s, 160 s, ...).
    /// An obstacle that flew straight for a minute, then round a 60 s circle: 80 s into the
    /// circle, its last 10 s (the signature) match the circle's first lap exactly, but the
    /// minute before them does not repeat the flight one period earlier (a straight line
    /// against the circle), so it is not taken for a periodic tour; checked against the
    /// signature alone (`validate_s` 0), which takes it for one.
    #[test]
    fn a_lap_the_signature_matches_but_the_flight_before_it_does_not_is_not_a_repeat() {
        let w = 2.0 * std::f64::consts::PI / 60.0;
        let r = 150.0;
        let circle = |s: f64| [r * (w * s).cos(), r * (w * s).sin()];
        // Straight into the circle's start along its tangent (continuous at t = 60).
        let flight = |t: f64| {
            if t >= 60.0 {
                circle(t - 60.0)
            } else {
                [r, r * w * (t - 60.0)]
            }
        };
        let t = track(flight, 140.0, 5.0);
        let signature_only = PeriodicConfig {
            validate_s: 0.0,
            ..PeriodicConfig::default()
        };
        let lap = find_lap(&t, &signature_only).expect("the signature matches");
        assert_eq!(lap.kind, LapKind::Repeat);
        assert!((lap.period_s - 60.0).abs() < 0.2, "{lap:?}");
        assert_eq!(find_lap(&t, &PeriodicConfig::default()), None);
        // Two whole laps later the minute before the signature repeats too: a lap again,
        // with the RMS of that minute (the track is noiseless: near 0).
        let t = track(flight, 200.0, 5.0);
        let lap = find_lap(&t, &PeriodicConfig::default()).expect("a lap");
        assert!(
            (lap.period_s - 60.0).abs() < 0.2 && lap.rms_m < 0.5,
            "{lap:?}"
        );
    }

    /// A repeat's spread is half its RMS (two noisy passes apart), floored, and does not grow
    /// with the time ahead; its timing jitter grows by a fortieth of a second a lap.
    #[test]
    fn a_repeats_spread_is_half_its_rms_and_its_jitter_grows_lap_by_lap() {
        let lap = Lap {
            period_s: 100.0,
            rms_m: 2.0,
            t0_s: 0.0,
            kind: LapKind::Repeat,
        };
        assert_eq!((lap.sigma_m(0.0), lap.sigma_m(50.0)), (1.0, 1.0));
        let exact = Lap { rms_m: 0.1, ..lap };
        assert_eq!(exact.sigma_m(10.0), LAP_MIN_SIGMA_M);
        assert!((lap.jitter_s(10.0) - 0.05).abs() < 1e-12);
        assert!((lap.jitter_s(150.0) - 0.075).abs() < 1e-12);
    }

    fn out_and_back(s: f64) -> [f64; 2] {
        let x = 300.0 * (2.0 * std::f64::consts::PI * (s - 10.0) / 120.0).sin();
        [x * 0.8, x * 0.6]
    }

    #[test]
    fn an_out_and_back_is_a_mirror_after_its_turn_back_then_a_repeat_after_a_whole_lap() {
        let cfg = PeriodicConfig::default();
        // 25 s after the turn-back: the last 10 s retrace the stretch 15-25 s before it.
        let t = track(out_and_back, 65.0, 5.0);
        let lap = find_lap(&t, &cfg).expect("a mirror");
        assert_eq!(lap.kind, LapKind::Mirror, "{lap:?}");
        assert!((lap.period_s - 50.0).abs() < 0.2, "{lap:?}");
        assert!(lap.rms_m < 1.0, "{lap:?}");
        // Ahead up to the track's start (15 s here), the track read backward.
        for s in [1.0, 5.0, 10.0, 14.5] {
            let p = lap.position(&t, s, 5.0).unwrap();
            let truth = out_and_back(65.0 + s);
            assert!(dist(p, truth) < 1.0, "+{s} s: {p:?} {truth:?}");
        }
        // Past it, nothing: the obstacle's own model predicts there.
        assert_eq!(lap.position(&t, 16.0, 5.0), None);
        // Within the window after the turn-back, with the shorter signature off
        // (`mirror_window_s` at the window), no mirror yet (nor anything else); with it, a
        // mirror 8 s after the turn-back (`a_fresh_turn_back_is_mirrored_on_the_newest_seconds`).
        let whole_window = PeriodicConfig {
            mirror_window_s: cfg.window_s,
            ..cfg
        };
        assert_eq!(
            find_lap(&track(out_and_back, 48.0, 5.0), &whole_window),
            None
        );
        let fresh = find_lap(&track(out_and_back, 48.0, 5.0), &cfg).expect("a fresh mirror");
        assert_eq!(fresh.kind, LapKind::Mirror, "{fresh:?}");
        assert!((fresh.period_s - 16.0).abs() < 0.2, "{fresh:?}");
        // Once a whole lap is seen, the repeat wins.
        let t = track(out_and_back, 140.0, 5.0);
        let lap = find_lap(&t, &cfg).expect("a lap");
        assert_eq!(lap.kind, LapKind::Repeat, "{lap:?}");
        assert!((lap.period_s - 120.0).abs() < 0.2, "{lap:?}");
    }

    /// A shuttle as the judges' two-waypoint tours fly it near a turn-back: 3 m/s^2 of
    /// constant deceleration into the tip at t = 40 s (250 m out along (0.8, 0.6)) and the
    /// same out of it, 18 m/s on the straight either side, symmetric in time about the tip.
    fn shuttle(s: f64) -> [f64; 2] {
        let d = (s - 40.0).abs();
        let x = if d <= 6.0 {
            250.0 - 1.5 * d * d
        } else {
            196.0 - 18.0 * (d - 6.0)
        };
        [x * 0.8, x * 0.6]
    }

    /// Issue 10 (Webster Field with mixed spheres, seed 464: a sphere on a two-waypoint tour
    /// 3-6 s past its turn-back was predicted round the turn, onto the escape that would
    /// have cleared it): a fresh turn-back is mirrored on the newest `mirror_window_s`
    /// (4 s), not a whole window (10 s) after the tip.
    #[test]
    fn a_fresh_turn_back_is_mirrored_on_the_newest_seconds() {
        let cfg = PeriodicConfig::default();
        // The shuttle seen at 5 Hz from `from` to `to`.
        let seen = |from: f64, to: f64| {
            let mut y = Track::default();
            let n = ((to - from) * 5.0).round() as u32;
            for k in 0..=n {
                let ts = from + f64::from(k) / 5.0;
                y.insert(
                    Observation {
                        t_s: ts,
                        p_m: shuttle(ts),
                        alt_m: 100.0,
                        radius_m: 10.0,
                    },
                    100.0,
                    2.0,
                );
            }
            y
        };
        // Seen from 16 s (24 s before the tip). 3 s after the tip: too soon even for the
        // shorter signature.
        assert_eq!(find_lap(&seen(16.0, 43.0), &cfg), None);
        // 4 s after: a mirror of period 8 s whose prediction is the flight back down the
        // line, for as far as the track reaches back (44 - 8 - 16 = 20 s).
        let t = seen(16.0, 44.0);
        let lap = find_lap(&t, &cfg).expect("a mirror 4 s after the tip");
        assert_eq!(lap.kind, LapKind::Mirror, "{lap:?}");
        assert!((lap.period_s - 8.0).abs() < 0.2, "{lap:?}");
        for s in [1.0, 5.0, 10.0, 19.5] {
            let p = lap.position(&t, s, 5.0).unwrap();
            let truth = shuttle(44.0 + s);
            assert!(dist(p, truth) < 1.0, "+{s} s: {p:?} {truth:?}");
        }
        // Without the shorter signature, nothing until the whole window has passed the tip.
        let off = PeriodicConfig {
            mirror_window_s: cfg.window_s,
            ..cfg
        };
        assert_eq!(find_lap(&t, &off), None);
        assert_eq!(find_lap(&seen(16.0, 49.0), &off), None);
        assert!(find_lap(&seen(16.0, 50.5), &off).is_some());
        // Nor for a track older than `fresh_mirror_max_track_s` (seen from -20 s: 64 s),
        // whose turn-backs its repeat, whole-window mirror or replay predict.
        assert_eq!(find_lap(&seen(-20.0, 44.0), &cfg), None);
        // A young track seen for only 10 s (6 s before the tip) is mirrored as well.
        let young = seen(34.0, 44.0);
        let lap = find_lap(&young, &cfg).expect("a young mirror");
        assert_eq!(lap.kind, LapKind::Mirror, "{lap:?}");
        let p = lap.position(&young, 1.5, 5.0).unwrap();
        assert!(dist(p, shuttle(45.5)) < 1.0, "{p:?}");
        // A sphere turning round in a circle (no line) is never mirrored so soon.
        let w = 18.0 / 60.0;
        let u_turn = track(|s| [60.0 * (w * s).cos(), 60.0 * (w * s).sin()], 12.0, 5.0);
        assert_eq!(find_lap(&u_turn, &cfg), None);
    }

    #[test]
    fn a_mirrors_point_ahead_moves_the_way_the_obstacle_will_and_spreads_by_its_jitter() {
        // The mirror reads the track backward, so the velocity it gives must still be the
        // obstacle's own ahead (not the reversed one of the stretch it reads).
        let t = track(out_and_back, 65.0, 5.0);
        let lap = find_lap(&t, &PeriodicConfig::default()).expect("a mirror");
        assert_eq!(lap.kind, LapKind::Mirror);
        let s = 5.0;
        let at = lap.at(&t, s, 5.0).expect("within the track");
        let (a, b) = (out_and_back(65.0 + s + 0.5), out_and_back(65.0 + s - 0.5));
        let truth = [a[0] - b[0], a[1] - b[1]];
        assert!(
            dist(at.velocity, truth) < 0.3,
            "{:?} {truth:?}",
            at.velocity
        );
        assert_eq!((at.sigma_m, at.jitter_s), (lap.sigma_m(s), lap.jitter_s(s)));
        // No deviate: the base; one sigma of timing: a jitter's worth of flight along it.
        assert_eq!(at.particle([0.0; 3]), at.base);
        let p = at.particle([1.0, 0.0, 0.0]);
        let along = [p[0] - at.base[0], p[1] - at.base[1]];
        let want = [at.velocity[0] * at.jitter_s, at.velocity[1] * at.jitter_s];
        assert!(dist(along, want) < 1e-9, "{along:?} {want:?}");
        let p = at.particle([0.0, 2.0, -1.0]);
        assert!(dist(p, [at.base[0] + 2.0 * at.sigma_m, at.base[1] - at.sigma_m]) < 1e-9);
        // Past the track's start nothing, as for the position.
        assert_eq!(lap.at(&t, 16.0, 5.0), None);
    }

    #[test]
    fn a_slow_out_and_back_is_not_a_mirror() {
        // 30 m either side every 120 s (at most 1.6 m/s): no lap matches, and the mirror,
        // which would match exactly, is refused because the signature spans 13 m (< 18).
        let slow = |s: f64| {
            let [x, y] = out_and_back(s);
            [x / 10.0, y / 10.0]
        };
        assert_eq!(
            find_lap(&track(slow, 65.0, 5.0), &PeriodicConfig::default()),
            None
        );
        // The same at 50 m either side (26 m spanned) is a mirror.
        let faster = |s: f64| {
            let [x, y] = out_and_back(s);
            [x / 6.0, y / 6.0]
        };
        let lap = find_lap(&track(faster, 65.0, 5.0), &PeriodicConfig::default());
        assert_eq!(lap.map(|l| l.kind), Some(LapKind::Mirror), "{lap:?}");
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
