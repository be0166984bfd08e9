//! Manoeuvre replay: an obstacle's future drawn from stretches of its own past flight,
//! turned and moved onto its present position and heading (seed 002's "advanced probability
//! mapping" and "consideration of past behavior" taken from one-second turn samples to whole
//! stretches of flight; issue 10, "prediction that exploits how obstacles really move").
//!
//! Seed 002 builds its distributions from the obstacle's own past turns: a histogram of
//! turn rates, then one conditioned on a slice of recent behaviour. Turn rates measured over
//! one second from noisy 2-5 Hz positions are mostly noise, and a histogram of them forgets
//! what happens over several decisions (a zigzag that cancels its own turns, a steady bias,
//! the fit error of the present heading and speed). Replay keeps whole stretches instead.
//!
//! At every observation `j` the obstacle's [`Frame`] is estimated causally, from
//! observations up to `j` only: its position (a least-squares fit evaluated at `t_j`) and
//! its heading (the slope of a straight-line fit over the last
//! [`ReplayConfig::heading_window_s`]). A particle picks an *anchor* observation `a` among
//! those of the last [`ReplayConfig::memory_s`] and flies the displacement the obstacle flew
//! after it, rotated into the present frame:
//! `x(s) = p_now + R(h_now - h_a) (P(t_a + s) - p_a)`, with `P` the observed track. When
//! the stretch runs out (the newest observation, or a gap longer than
//! [`ReplayConfig::max_gap_s`]) the particle chains on from where it is, heading as the
//! stretch ended, with another anchor: a block bootstrap of the obstacle's own manoeuvres.
//!
//! Novelty: the past holds only what the obstacle has shown. Having watched it for `m`
//! seconds of memory, each particle leaves its replay at an exponential time of rate `1/m`
//! (the longer the watch without a new kind of flight, the rarer one is) and flies on from
//! there at the estimated speed turning uniformly within the estimated capability, redrawn
//! every decision interval (seed 002's random probability mapping). A short watch so
//! keeps broad tails far ahead (a tour's first bend, a turn-back not yet seen); a long one
//! barely changes the replay.
//!
//! The spread needs no tuned constant: the anchors' frames are estimated by the same
//! estimator from the same noisy stream as the present one, so their errors (position,
//! heading) are alike, and the particles' spread about their centre matches the truth's
//! deviation from it. The displacements carry the obstacle's real speed, turning, bias and
//! pattern, in the proportions it has shown. What replay cannot know is behaviour it has not
//! yet shown; until there is [`ReplayConfig::min_history_s`] of it, the stage models
//! (random, advanced, memory) and a young track's quadratic ([`crate::young`]) stand in.
//!
//! Smooth flight: an obstacle flying a smooth curve (the judges' spline tours: each axis a
//! cubic in time) is extrapolated far better by a quadratic in time fitted to its last
//! [`ReplayConfig::smooth_window_s`] than by replaying its past displacements, whose turns
//! and speeds need not be the present ones. Which of the two to trust is read from the
//! obstacle's own past, without a tuned threshold: at anchors of the memory, the quadratic
//! fitted there and flown [`ReplayConfig::smooth_horizons_s`] ahead misses what the obstacle
//! then flew by some mean square; the replayed displacements spread about their mean by
//! some variance. Where the first is smaller, from the first horizon on, each particle
//! flies the present quadratic plus its anchor's deviation from the anchor's own quadratic
//! (turned onto the present heading) up to the last horizon won, then chains on into the
//! replay from where it is. A random turner's quadratics miss by more than its replay
//! spreads, so it keeps plain replay.
//!
//! A turn under way: anchors drawn uniformly replay the obstacle's manoeuvres in the
//! proportions it has flown them, whatever it is flying now, so a sphere two seconds into
//! a sustained turn is mostly predicted to fly on straight (most of its past is). Each frame
//! carries the turn flown before it ([`Frame::turn_radps`]: its heading's change from the
//! frame [`ReplayConfig::turn_lag_s`] older), and a share of the particles
//! ([`ReplayConfig::turn_share`]) draw their first anchor weighted by how alike the turn
//! before it is to the turn flown now: a Gaussian kernel whose bandwidth is Silverman's
//! rule over the anchors' turns, so no scale is tuned (the method of analogues). Where the
//! next turn does not depend on the present one (a random turner redrawing every second)
//! the alike anchors fly the same futures as any other and only sample size is lost; where
//! it does (a turn held for seconds, a zigzag's alternation, a turn back into its area)
//! the replay follows it. The other particles keep uniform anchors, so a present turn that
//! misleads still leaves what the obstacle has shown covered; chained anchors are uniform.
//!
//! Frames are a pure function of the track (an out-of-order observation redoes the frames
//! from its place on), so a predictor fed batch by batch and one rebuilt from the same rows
//! agree.
//!
//! # Units
//! ENU metres, seconds, radians (heading counter-clockwise from east).

use crate::track::{Observation, Track};
use rand::Rng;

/// Replay parameters, with documented defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct ReplayConfig {
    /// Window of the fits that give a frame, seconds. Default 2.
    pub heading_window_s: f64,
    /// Observed flight needed before replay is used, seconds. Default 20.
    pub min_history_s: f64,
    /// Oldest flight replayed, seconds before the newest observation. Default 600.
    pub memory_s: f64,
    /// Shortest stretch an anchor must have after it, seconds. Default 2.
    pub min_stretch_s: f64,
    /// A stretch ends at a gap between observations longer than this, seconds. Default 3.
    pub max_gap_s: f64,
    /// Below this fitted speed a frame has no heading (and is no anchor), m/s. Default 0.5.
    pub stationary_speed_mps: f64,
    /// Particles leave their replay at a rate of one over the watched time (see the module
    /// docs, "Novelty"). Default on.
    pub novelty: bool,
    /// Window of the quadratic fits of the smooth extrapolation (see the module docs,
    /// "Smooth flight"), seconds; 0 disables it. Default 8.
    pub smooth_window_s: f64,
    /// Horizons at which the smooth extrapolation is tested against the replay on the
    /// obstacle's own past, seconds, ascending; it is flown up to the last one it wins in
    /// a row from the first. Default 5, 10.
    pub smooth_horizons_s: [f64; 2],
    /// While the track is younger than `min_history_s`, particles fly the quadratic through
    /// its last `smooth_window_s` for this long, then turn as the stage model does
    /// ([`crate::young`]); 0 disables. Seconds. Default 10.
    pub young_horizon_s: f64,
    /// Spread of a young particle's jerk per axis (what a quadratic leaves out), m/s^3.
    /// Default 0.1.
    pub young_jerk_mps3: f64,
    /// Shortest watch a young quadratic is fitted to, seconds. Default 2.
    pub young_min_span_s: f64,
    /// Least standard deviation of a young fit's residuals per axis, metres. Default 0.5.
    pub young_noise_floor_m: f64,
    /// Share of a young track's particles that fly its quadratic; the others fly the stage
    /// model from the start. Default 0.5.
    pub young_share: f64,
    /// A young track's stage model turns with its shown bias: the mean of its turn
    /// samples less this many standard errors ([`crate::young::turn_bias_radps`]); 0
    /// disables. Default 0 (off: measured at 2 in the README, "A young track's lean").
    pub young_bias_se: f64,
    /// Share of the particles that fly a spline tour's present leg ([`crate::leg`]) beside
    /// the model's own; 0 disables. Default 0.5.
    pub leg_share: f64,
    /// Shortest leg trusted, seconds. Default 8.
    pub leg_min_s: f64,
    /// Noisiest feed legs are fitted from: the pooled residual standard deviation per
    /// axis, metres. Default 0.25 (the judges' server sends exact positions).
    pub leg_max_noise_m: f64,
    /// Mean of the exponential time to a leg's end past its shortest length, seconds.
    /// Default 20.
    pub leg_knot_mean_s: f64,
    /// Shortest leg of a tour, metres: no particle leaves the cubic before the leg is this
    /// long at the present speed. Default 100.
    pub leg_min_length_m: f64,
    /// Share of a replay's particles whose first anchor is drawn by how alike the turn
    /// flown before it is to the turn flown now (see the module docs, "A turn under way");
    /// the others draw theirs uniformly. 0 disables. Default 0.5.
    pub turn_share: f64,
    /// Span over which the turn flown before an observation is measured: the change of its
    /// frame's heading from the frame this long before, seconds. Default 1.
    pub turn_lag_s: f64,
}

impl Default for ReplayConfig {
    fn default() -> Self {
        Self {
            heading_window_s: 2.0,
            min_history_s: 20.0,
            memory_s: 600.0,
            min_stretch_s: 2.0,
            max_gap_s: 3.0,
            stationary_speed_mps: 0.5,
            novelty: true,
            smooth_window_s: 8.0,
            smooth_horizons_s: [5.0, 10.0],
            young_horizon_s: 10.0,
            young_jerk_mps3: 0.1,
            young_min_span_s: 2.0,
            young_noise_floor_m: 0.5,
            young_share: 0.5,
            young_bias_se: 0.0,
            leg_share: 0.5,
            leg_min_s: 8.0,
            leg_max_noise_m: 0.25,
            leg_knot_mean_s: 20.0,
            leg_min_length_m: 100.0,
            turn_share: 0.5,
            turn_lag_s: 1.0,
        }
    }
}

/// Where an obstacle was at one observation and which way it flew, estimated from the
/// observations up to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Fitted position, ENU metres.
    pub p_m: [f64; 2],
    /// Heading of the straight-line fit, radians counter-clockwise from east.
    pub heading_rad: f64,
    /// The turn flown before it: the change of heading from the newest frame at least
    /// [`ReplayConfig::turn_lag_s`] older (and at most twice that), over the time between,
    /// rad/s. `None` without such a frame.
    pub turn_radps: Option<f64>,
}

/// The frames of every observation of one track, kept in step with it.
#[derive(Debug, Default)]
pub struct Manoeuvres {
    frames: Vec<Option<Frame>>,
}

impl Clone for Manoeuvres {
    fn clone(&self) -> Self {
        Self {
            frames: crate::track::clone_with_headroom(&self.frames),
        }
    }
}

impl Manoeuvres {
    /// Redoes the frames after an observation was inserted at index `inserted` of `track`
    /// (later frames' windows may hold it; earlier ones cannot).
    pub fn update(&mut self, track: &Track, inserted: usize, cfg: &ReplayConfig) {
        let obs = track.observations();
        self.frames.truncate(inserted.min(self.frames.len()));
        for j in self.frames.len()..obs.len() {
            let f = frame_at(obs, j, cfg).map(|f| Frame {
                turn_radps: turn_before(obs, &self.frames, j, f.heading_rad, cfg.turn_lag_s),
                ..f
            });
            self.frames.push(f);
        }
    }

    /// One frame per observation of the track (`None` where too few observations or too
    /// slow).
    pub fn frames(&self) -> &[Option<Frame>] {
        &self.frames
    }

    /// Whether `track` has enough history with frames for replay: its newest observation has
    /// a frame and the first frame within the memory is `min_history_s` older.
    pub fn ready(&self, track: &Track, cfg: &ReplayConfig) -> bool {
        let obs = track.observations();
        let (Some(last), Some(Some(_))) = (obs.last(), self.frames.last()) else {
            return false;
        };
        let from = obs.partition_point(|o| o.t_s < last.t_s - cfg.memory_s);
        self.frames[from..]
            .iter()
            .zip(&obs[from..])
            .find(|(f, _)| f.is_some())
            .is_some_and(|(_, o)| last.t_s - o.t_s >= cfg.min_history_s)
    }

    /// Fastest average speed over any `span_s` of the replayed memory, m/s: what bounds a
    /// replayed particle's reach (the threat filter's).
    pub fn max_speed_mps(&self, track: &Track, cfg: &ReplayConfig, span_s: f64) -> f64 {
        let obs = track.observations();
        let Some(last) = obs.last() else {
            return 0.0;
        };
        let from = obs.partition_point(|o| o.t_s < last.t_s - cfg.memory_s);
        let w = &obs[from..];
        let mut best: f64 = 0.0;
        let mut i = 0;
        for j in 0..w.len() {
            while i < j && w[j].t_s - w[i + 1].t_s >= span_s {
                i += 1;
            }
            let dt = w[j].t_s - w[i].t_s;
            if dt >= span_s {
                best = best.max(geom::dist(w[i].p_m, w[j].p_m) / dt);
            }
        }
        best
    }
}

/// The turn flown before observation `j` (heading `heading_rad`), from the frames before it
/// ([`Frame::turn_radps`]).
fn turn_before(
    obs: &[Observation],
    frames: &[Option<Frame>],
    j: usize,
    heading_rad: f64,
    lag_s: f64,
) -> Option<f64> {
    let t = obs[j].t_s;
    let below = obs[..j.min(frames.len())].partition_point(|o| o.t_s <= t - lag_s);
    let (i, fi) = (0..below)
        .rev()
        .map_while(|i| (t - obs[i].t_s <= 2.0 * lag_s).then_some(i))
        .find_map(|i| frames[i].map(|f| (i, f)))?;
    Some(geom::wrap_pi(heading_rad - fi.heading_rad) / (t - obs[i].t_s))
}

/// The frame at observation `j` from the observations of the last `heading_window_s` up to
/// it: at least 3 spanning half the window, a speed above the stationary one.
fn frame_at(obs: &[Observation], j: usize, cfg: &ReplayConfig) -> Option<Frame> {
    let t = obs[j].t_s;
    let from = obs[..=j].partition_point(|o| o.t_s < t - cfg.heading_window_s);
    let win = &obs[from..=j];
    if win.len() < 3 || t - win[0].t_s < 0.5 * cfg.heading_window_s {
        return None;
    }
    let n = win.len() as f64;
    let tm = win.iter().map(|o| o.t_s - t).sum::<f64>() / n;
    let (mut sxx, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for o in win {
        let d = o.t_s - t - tm;
        sxx += d * d;
        sx += d * o.p_m[0];
        sy += d * o.p_m[1];
    }
    if sxx <= 0.0 {
        return None;
    }
    let v = [sx / sxx, sy / sxx];
    if v[0].hypot(v[1]) < cfg.stationary_speed_mps {
        return None;
    }
    let (p_m, _) = crate::estimate::fit_velocity(win, t)?;
    Some(Frame {
        p_m,
        heading_rad: v[1].atan2(v[0]),
        turn_radps: None,
    })
}

/// A quadratic in time fitted to observations, about the time `t0_s` of its newest one.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Quad {
    t0_s: f64,
    /// `[x, y]` coefficients of `1, u, u^2` with `u = t - t0_s`.
    c: [[f64; 3]; 2],
}

impl Quad {
    fn at(&self, u: f64) -> [f64; 2] {
        let [x, y] = self.c;
        [x[0] + u * (x[1] + u * x[2]), y[0] + u * (y[1] + u * y[2])]
    }

    fn heading(&self) -> f64 {
        self.c[1][1].atan2(self.c[0][1])
    }
}

/// The least-squares quadratic through the observations of the last `window_s` up to `j`:
/// at least 6 spanning three quarters of the window, moving faster than `stationary_mps`.
fn quad_at(obs: &[Observation], j: usize, window_s: f64, stationary_mps: f64) -> Option<Quad> {
    let t0 = obs[j].t_s;
    let from = obs[..=j].partition_point(|o| o.t_s < t0 - window_s);
    let win = &obs[from..=j];
    if win.len() < 6 || t0 - win[0].t_s < 0.75 * window_s {
        return None;
    }
    // Normal equations on u / window (conditioning), solved by Cramer's rule.
    let sc = 1.0 / window_s;
    let mut m = [0.0; 5];
    let mut b = [[0.0; 3]; 2];
    for o in win {
        let u = (o.t_s - t0) * sc;
        let mut f = 1.0;
        for (k, mk) in m.iter_mut().enumerate() {
            *mk += f;
            if k < 3 {
                b[0][k] += f * o.p_m[0];
                b[1][k] += f * o.p_m[1];
            }
            f *= u;
        }
    }
    let a = [[m[0], m[1], m[2]], [m[1], m[2], m[3]], [m[2], m[3], m[4]]];
    let det3 = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det3(a);
    if d.abs() < 1e-12 {
        return None;
    }
    let mut c = [[0.0; 3]; 2];
    for (axis, cb) in b.iter().enumerate() {
        for k in 0..3 {
            let mut ak = a;
            for r in 0..3 {
                ak[r][k] = cb[r];
            }
            c[axis][k] = det3(ak) / d * sc.powi(k as i32);
        }
    }
    let q = Quad { t0_s: t0, c };
    (q.c[0][1].hypot(q.c[1][1]) >= stationary_mps).then_some(q)
}

/// The track's position at time `u` (linear between observations, held at `end`), moving
/// the cursor `k` forward to the observation at or before it.
fn track_at(obs: &[Observation], k: &mut usize, end: usize, u: f64) -> [f64; 2] {
    while *k < end && obs[*k + 1].t_s <= u {
        *k += 1;
    }
    let k = *k;
    if k < end {
        let (a, b) = (&obs[k], &obs[k + 1]);
        let f = ((u - a.t_s) / (b.t_s - a.t_s)).clamp(0.0, 1.0);
        [
            a.p_m[0] + (b.p_m[0] - a.p_m[0]) * f,
            a.p_m[1] + (b.p_m[1] - a.p_m[1]) * f,
        ]
    } else {
        obs[end].p_m
    }
}

/// A particle flying the present quadratic plus an anchor's deviation from its own.
#[derive(Debug, Clone, Copy)]
struct Smooth {
    anchor: u32,
    /// The observation at or before the particle's track time (search cursor).
    cur: u32,
    quad: Quad,
    /// Rotation from the anchor's quadratic's heading to the present one's.
    c: f64,
    s: f64,
    /// Elapsed time up to which it flies so.
    until_s: f64,
}

const NONE: u32 = u32::MAX;

/// Replayed particles (struct of arrays): each flies a stretch of the track from its anchor,
/// rotated by `(c, s)` and moved from the anchor's `r` to `o`; track time `u = u0 + e` at
/// `e` seconds after the start.
#[derive(Debug, Clone)]
pub struct ReplayParticles<'a> {
    obs: &'a [Observation],
    frames: &'a [Option<Frame>],
    /// First observation index of the memory (`run_end` is indexed from it).
    base: usize,
    /// Per observation from `base`: the last observation with a frame in its gap-free run.
    run_end: Vec<u32>,
    anchors: Vec<u32>,
    cur: Vec<u32>,
    end: Vec<u32>,
    phi: Vec<f64>,
    c: Vec<f64>,
    s: Vec<f64>,
    o: Vec<[f64; 2]>,
    r: Vec<[f64; 2]>,
    u0: Vec<f64>,
    /// Elapsed time at which each particle leaves its replay (novelty).
    t_novel: Vec<f64>,
    /// Particles that left: position, unit heading, turn rate, elapsed time, next decision.
    free: Vec<Option<Free>>,
    novel: Novel,
    /// The present quadratic, when smooth flight beat the replay on the obstacle's past.
    now_quad: Option<Quad>,
    /// Particles still on the smooth extrapolation.
    smooth: Vec<Option<Smooth>>,
}

/// What a particle flies after leaving its replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Novel {
    /// Speed, m/s.
    pub speed_mps: f64,
    /// Turn-rate capability, rad/s (uniform turns within it).
    pub w_max_radps: f64,
    /// Decision interval of the turns, seconds.
    pub decision_interval_s: f64,
}

#[derive(Debug, Clone, Copy)]
struct Free {
    p: [f64; 2],
    u: [f64; 2],
    omega: f64,
    e: f64,
    next: f64,
}

fn unit<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    ((rng.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

impl<'a> ReplayParticles<'a> {
    /// `n` particles at the newest observation's frame, each on its own anchor. `None`
    /// when the newest observation has no frame or no anchor has a long enough stretch.
    pub fn new<R: Rng + ?Sized>(
        track: &'a Track,
        manoeuvres: &'a Manoeuvres,
        cfg: &ReplayConfig,
        novel: Novel,
        n: usize,
        rng: &mut R,
    ) -> Option<Self> {
        let obs = track.observations();
        let frames = manoeuvres.frames();
        if frames.len() != obs.len() {
            return None;
        }
        let last = obs.last()?;
        let now = (*frames.last()?)?;
        let base = obs.partition_point(|o| o.t_s < last.t_s - cfg.memory_s);
        let mut run_end = vec![NONE; obs.len() - base];
        let mut re = NONE;
        for k in (base..obs.len()).rev() {
            if k + 1 == obs.len() || obs[k + 1].t_s - obs[k].t_s > cfg.max_gap_s {
                re = NONE;
            }
            if re == NONE && frames[k].is_some() {
                re = k as u32;
            }
            run_end[k - base] = re;
        }
        let anchors: Vec<u32> = (base..obs.len())
            .filter(|&k| {
                let re = run_end[k - base];
                frames[k].is_some()
                    && re != NONE
                    && obs[re as usize].t_s - obs[k].t_s >= cfg.min_stretch_s
            })
            .map(|k| k as u32)
            .collect();
        if anchors.is_empty() {
            return None;
        }
        let first = (base..obs.len()).find(|&k| frames[k].is_some())?;
        let watched_s = (last.t_s - obs[first].t_s).max(cfg.min_stretch_s);
        let mut p = Self {
            obs,
            frames,
            base,
            run_end,
            anchors,
            cur: vec![0; n],
            end: vec![0; n],
            phi: vec![0.0; n],
            c: vec![0.0; n],
            s: vec![0.0; n],
            o: vec![[0.0; 2]; n],
            r: vec![[0.0; 2]; n],
            u0: vec![0.0; n],
            t_novel: vec![f64::INFINITY; n],
            free: vec![None; n],
            novel,
            now_quad: None,
            smooth: vec![None; n],
        };
        let smooth_s = p.smooth_horizon(cfg);
        let alike = (cfg.turn_share > 0.0)
            .then(|| now.turn_radps.and_then(|w| p.turn_alike(w)))
            .flatten();
        let n_alike = alike
            .as_ref()
            .map_or(0, |_| ((cfg.turn_share * n as f64).round() as usize).min(n));
        for i in 0..n {
            if cfg.novelty {
                p.t_novel[i] = -unit(rng).ln() * watched_s;
            }
            let a = match &alike {
                Some(cdf) if i < n_alike => p.draw_weighted(cdf, rng),
                _ => p.draw(rng),
            };
            let fa = p.frames[a].expect("anchors have frames");
            p.start(i, a, now.p_m, now.heading_rad, fa.p_m, 0.0);
            if let (Some(q_now), Some(h)) = (p.now_quad, smooth_s)
                && let Some(qa) = quad_at(obs, a, cfg.smooth_window_s, cfg.stationary_speed_mps)
            {
                let end = p.end[i] as usize;
                let (s, c) = (q_now.heading() - qa.heading()).sin_cos();
                p.smooth[i] = Some(Smooth {
                    anchor: a as u32,
                    cur: a as u32,
                    quad: qa,
                    c,
                    s,
                    until_s: h.min(obs[end].t_s - obs[a].t_s),
                });
            }
        }
        Some(p)
    }

    /// How far ahead particles fly the smooth extrapolation (module docs, "Smooth flight"):
    /// the last of [`ReplayConfig::smooth_horizons_s`], from the first on, at which the
    /// present quadratic plus the past's deviations from their own quadratics missed the
    /// past by less (mean square) than the replayed displacements spread about their mean.
    /// `None` (plain replay) when it loses at the first, or without a present quadratic.
    fn smooth_horizon(&mut self, cfg: &ReplayConfig) -> Option<f64> {
        if cfg.smooth_window_s <= 0.0 {
            return None;
        }
        let obs = self.obs;
        let last = obs.len() - 1;
        let q_now = quad_at(obs, last, cfg.smooth_window_s, cfg.stationary_speed_mps)?;
        let stride = self.anchors.len().div_ceil(256).max(1);
        let h_min = cfg.smooth_horizons_s[0];
        let tested: Vec<(usize, usize, Quad)> = self
            .anchors
            .iter()
            .step_by(stride)
            .filter_map(|&a| {
                let a = a as usize;
                let end = self.run_end[a - self.base] as usize;
                (obs[end].t_s - obs[a].t_s >= h_min)
                    .then(|| quad_at(obs, a, cfg.smooth_window_s, cfg.stationary_speed_mps))
                    .flatten()
                    .map(|q| (a, end, q))
            })
            .collect();
        let mut best = None;
        for &h in &cfg.smooth_horizons_s {
            let (mut n, mut e2, mut d, mut d2) = (0usize, 0.0, [0.0; 2], 0.0);
            for &(a, end, qa) in &tested {
                if obs[end].t_s - obs[a].t_s < h {
                    continue;
                }
                let fa = self.frames[a].expect("anchors have frames");
                let mut k = a;
                let pa = track_at(obs, &mut k, end, obs[a].t_s + h);
                // Replay: the displacement after the anchor, turned onto the present heading.
                let (s, c) = (-fa.heading_rad).sin_cos();
                let (dx, dy) = (pa[0] - fa.p_m[0], pa[1] - fa.p_m[1]);
                let r = [c * dx - s * dy, s * dx + c * dy];
                d[0] += r[0];
                d[1] += r[1];
                d2 += r[0] * r[0] + r[1] * r[1];
                // Smooth: the deviation from the anchor's own quadratic.
                let qp = qa.at(h);
                e2 += (pa[0] - qp[0]).powi(2) + (pa[1] - qp[1]).powi(2);
                n += 1;
            }
            if n < 10 {
                break;
            }
            let nf = n as f64;
            let spread2 = d2 / nf - (d[0] / nf).powi(2) - (d[1] / nf).powi(2);
            if e2 / nf >= spread2 {
                break;
            }
            best = Some(h);
        }
        if best.is_some() {
            self.now_quad = Some(q_now);
        }
        best
    }

    /// Particle `i`'s position on its smooth extrapolation `e` seconds after the start
    /// (`e` never decreasing between calls with the same `sm`, whose cursor it moves).
    fn smooth_at(&self, sm: &mut Smooth, e: f64) -> [f64; 2] {
        let q_now = self
            .now_quad
            .expect("smooth particles have a present quadratic");
        let a = sm.anchor as usize;
        let end = self.run_end[a - self.base] as usize;
        let u = self.obs[a].t_s + e;
        let mut k = sm.cur as usize;
        let pa = track_at(self.obs, &mut k, end, u);
        sm.cur = k as u32;
        let qa = sm.quad.at(e);
        let (dx, dy) = (pa[0] - qa[0], pa[1] - qa[1]);
        let q = q_now.at(e);
        [q[0] + sm.c * dx - sm.s * dy, q[1] + sm.s * dx + sm.c * dy]
    }

    /// Heading of particle `i`'s smooth extrapolation at `e`: over its last half second.
    fn smooth_heading(&self, sm: &Smooth, e: f64) -> f64 {
        let mut back = Smooth {
            cur: sm.anchor,
            ..*sm
        };
        let p0 = self.smooth_at(&mut back, (e - 0.5).max(0.0));
        let p1 = self.smooth_at(&mut back, e);
        if (p1[0] - p0[0]).hypot(p1[1] - p0[1]) > 1e-9 {
            (p1[1] - p0[1]).atan2(p1[0] - p0[0])
        } else {
            self.now_quad.map_or(0.0, |q| q.heading())
        }
    }

    /// Cumulative weights over the anchors: a Gaussian kernel in the turn flown before each
    /// anchor about `now_radps`, the bandwidth by Silverman's rule over the anchors' turns
    /// (module docs, "A turn under way"). `None` with fewer than 20 anchors with a turn.
    fn turn_alike(&self, now_radps: f64) -> Option<Vec<f64>> {
        let turn = |a: u32| self.frames[a as usize].and_then(|f| f.turn_radps);
        let (mut n, mut sum, mut sum2) = (0usize, 0.0, 0.0);
        for w in self.anchors.iter().filter_map(|&a| turn(a)) {
            n += 1;
            sum += w;
            sum2 += w * w;
        }
        if n < 20 {
            return None;
        }
        let mean = sum / n as f64;
        let sd = (sum2 / n as f64 - mean * mean).max(0.0).sqrt();
        let h = (1.06 * sd * (n as f64).powf(-0.2)).max(1e-3);
        let mut acc = 0.0;
        let cdf: Vec<f64> = self
            .anchors
            .iter()
            .map(|&a| {
                if let Some(w) = turn(a) {
                    acc += (-0.5 * ((w - now_radps) / h).powi(2)).exp();
                }
                acc
            })
            .collect();
        (acc > 0.0).then_some(cdf)
    }

    /// An anchor drawn by the cumulative weights `cdf` ([`ReplayParticles::turn_alike`]).
    fn draw_weighted<R: Rng + ?Sized>(&self, cdf: &[f64], rng: &mut R) -> usize {
        let r = unit(rng) * cdf[cdf.len() - 1];
        let k = cdf.partition_point(|&c| c < r).min(self.anchors.len() - 1);
        self.anchors[k] as usize
    }

    fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> usize {
        let k = ((rng.next_u64() >> 32) * self.anchors.len() as u64) >> 32;
        self.anchors[k as usize] as usize
    }

    /// Puts particle `i` on anchor `a` at `e` seconds: it is at `at` heading `heading`, and
    /// the anchor's own reference point is `r`.
    fn start(&mut self, i: usize, a: usize, at: [f64; 2], heading: f64, r: [f64; 2], e: f64) {
        let fa = self.frames[a].expect("anchors have frames");
        let phi = heading - fa.heading_rad;
        let (s, c) = phi.sin_cos();
        self.cur[i] = a as u32;
        self.end[i] = self.run_end[a - self.base];
        self.phi[i] = phi;
        self.c[i] = c;
        self.s[i] = s;
        self.o[i] = at;
        self.r[i] = r;
        self.u0[i] = self.obs[a].t_s - e;
    }

    fn place(&self, i: usize, q: [f64; 2]) -> [f64; 2] {
        let (dx, dy) = (q[0] - self.r[i][0], q[1] - self.r[i][1]);
        [
            self.o[i][0] + self.c[i] * dx - self.s[i] * dy,
            self.o[i][1] + self.s[i] * dx + self.c[i] * dy,
        ]
    }

    /// Particle `i`'s replayed position `e` seconds after the start (never backwards).
    fn replayed<R: Rng + ?Sized>(&mut self, i: usize, e: f64, rng: &mut R) -> [f64; 2] {
        if let Some(mut sm) = self.smooth[i] {
            if e <= sm.until_s {
                let p = self.smooth_at(&mut sm, e);
                self.smooth[i] = Some(sm);
                return p;
            }
            // The smooth stretch ended: chain on into the replay from where it is.
            let until = sm.until_s;
            let at = self.smooth_at(&mut sm, until);
            let he = self.smooth_heading(&sm, sm.until_s);
            self.smooth[i] = None;
            let a = self.draw(rng);
            self.start(i, a, at, he, self.obs[a].p_m, sm.until_s);
        }
        loop {
            let u = self.u0[i] + e;
            let end = self.end[i] as usize;
            if u > self.obs[end].t_s {
                // The stretch ran out: chain on from its end, heading as it ended.
                let at = self.place(i, self.obs[end].p_m);
                let he = self.frames[end].expect("run ends have frames").heading_rad + self.phi[i];
                let e_end = self.obs[end].t_s - self.u0[i];
                let a = self.draw(rng);
                self.start(i, a, at, he, self.obs[a].p_m, e_end);
                continue;
            }
            let mut k = self.cur[i] as usize;
            let q = track_at(self.obs, &mut k, end, u);
            self.cur[i] = k as u32;
            return self.place(i, q);
        }
    }

    /// The heading particle `i` replays at its cursor: the newest frame at or before it.
    fn replayed_heading(&self, i: usize) -> f64 {
        let k = self.cur[i] as usize;
        (0..=k)
            .rev()
            .take(64)
            .find_map(|j| self.frames[j])
            .map_or(self.phi[i], |f| f.heading_rad + self.phi[i])
    }

    /// Moves every particle to `e_s` seconds after the start (never backwards) and writes
    /// their positions into `x`, `y`.
    pub fn advance_to<R: Rng + ?Sized>(
        &mut self,
        e_s: f64,
        x: &mut [f64],
        y: &mut [f64],
        rng: &mut R,
    ) {
        let Novel {
            speed_mps: v,
            w_max_radps: w,
            decision_interval_s: dti,
        } = self.novel;
        for i in 0..self.cur.len() {
            if self.free[i].is_none() {
                if e_s <= self.t_novel[i] {
                    [x[i], y[i]] = self.replayed(i, e_s, rng);
                    continue;
                }
                let p = self.replayed(i, self.t_novel[i], rng);
                let h = match self.smooth[i] {
                    Some(sm) => self.smooth_heading(&sm, self.t_novel[i]),
                    None => self.replayed_heading(i),
                };
                let (uy, ux) = h.sin_cos();
                self.free[i] = Some(Free {
                    p,
                    u: [ux, uy],
                    omega: 0.0,
                    e: self.t_novel[i],
                    next: self.t_novel[i],
                });
            }
            let f = self.free[i].as_mut().expect("set above");
            while f.e < e_s {
                if f.e >= f.next - 1e-9 {
                    f.omega = (2.0 * unit(rng) - 1.0) * w;
                    f.next += dti;
                }
                let h = e_s.min(f.next) - f.e;
                let Arc { a, b, s, c } = arc(f.omega, h);
                let [ux, uy] = f.u;
                f.p[0] += v * (a * ux - b * uy);
                f.p[1] += v * (a * uy + b * ux);
                f.u = [c * ux - s * uy, s * ux + c * uy];
                f.e += h;
            }
            [x[i], y[i]] = f.p;
        }
    }
}

/// One step of a constant turn: `omega * h` radians in `h` seconds. A unit-speed body
/// heading `u` moves by `a u + b u_left`; its heading turns by `(s, c)` (sine and cosine).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Arc {
    /// `sin(omega h) / omega`, seconds (`h` when straight).
    a: f64,
    /// `(1 - cos(omega h)) / omega`, seconds (0 when straight).
    b: f64,
    /// `sin(omega h)`.
    s: f64,
    /// `cos(omega h)`.
    c: f64,
}

/// Above this turn per step (radians) [`arc`] calls `sin_cos`; at or below it, the series
/// agree with it to a few units in the last place (the first term left out is below
/// 4e-14 of the sum).
const ARC_SERIES_MAX_RAD: f64 = 0.5;

/// The step of a constant turn ([`Arc`]). The free particles of a replay take one per
/// particle and decision interval, with turns of a fraction of a radian: there the
/// Taylor series of `sin(x) / x` and `(1 - cos x) / x^2` (even polynomials, no division by
/// the turn rate) replace a `sin_cos` and two divisions (a full rebuild of 10 obstacles 7%
/// faster, `cargo bench -p predictor --bench risk_map -- full_rebuild`).
fn arc(omega: f64, h: f64) -> Arc {
    let th = omega * h;
    if th.abs() > ARC_SERIES_MAX_RAD {
        let (s, c) = th.sin_cos();
        return Arc {
            a: s / omega,
            b: (1.0 - c) / omega,
            s,
            c,
        };
    }
    let x2 = th * th;
    // sin(x) / x and (1 - cos x) / x^2 to the x^10 term, in Horner form (the coefficients
    // are constants: no division at run time).
    let sinc = 1.0
        + x2 * (-1.0 / 6.0
            + x2 * (1.0 / 120.0
                + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0 + x2 * (-1.0 / 39_916_800.0)))));
    let versc = 0.5
        + x2 * (-1.0 / 24.0
            + x2 * (1.0 / 720.0
                + x2 * (-1.0 / 40_320.0 + x2 * (1.0 / 3_628_800.0 + x2 * (-1.0 / 479_001_600.0)))));
    Arc {
        a: h * sinc,
        b: h * th * versc,
        s: th * sinc,
        c: 1.0 - x2 * versc,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn a_turn_steps_series_agree_with_sin_and_cos_to_the_last_places() {
        // Turns either side of the switch to sin_cos, both directions, steps short and long.
        let mut worst = 0.0f64;
        for h in [1e-3, 0.05, 0.2, 0.5, 1.0, 2.0] {
            for k in -2000..=2000 {
                let omega = f64::from(k) * 1e-3; // -2 ..= 2 rad/s
                let got = arc(omega, h);
                let th = omega * h;
                let (s, c) = th.sin_cos();
                // 1 - cos x = 2 sin^2(x / 2), without the cancellation of small turns.
                let (a, b) = if omega == 0.0 {
                    (h, 0.0)
                } else {
                    (s / omega, 2.0 * (0.5 * th).sin().powi(2) / omega)
                };
                for (x, want, scale) in [
                    (got.a, a, h),
                    (got.b, b, h),
                    (got.s, s, 1.0),
                    (got.c, c, 1.0),
                ] {
                    worst = worst.max((x - want).abs() / scale);
                }
            }
        }
        assert!(worst < 1e-13, "worst relative difference {worst:e}");
        // Straight is exact.
        assert_eq!(
            arc(0.0, 0.7),
            Arc {
                a: 0.7,
                b: 0.0,
                s: 0.0,
                c: 1.0
            }
        );
    }

    fn circle_track(secs: f64, hz: f64, w: f64, v: f64) -> (Track, Manoeuvres) {
        let cfg = ReplayConfig::default();
        let mut t = Track::default();
        let mut m = Manoeuvres::default();
        let n = (secs * hz) as usize;
        for k in 0..=n {
            let ts = k as f64 / hz;
            let a = w * ts;
            let o = Observation {
                t_s: ts,
                p_m: [v / w * a.sin(), v / w * (1.0 - a.cos())],
                alt_m: 50.0,
                radius_m: 10.0,
            };
            if let (_, Some(i)) = t.insert(o, 100.0, 0.0) {
                m.update(&t, i, &cfg);
            }
        }
        (t, m)
    }

    /// A track of `f(t)` seen at `hz` for `secs` with Gaussian noise `sigma_m` per axis.
    fn noisy_track(
        secs: f64,
        hz: f64,
        sigma_m: f64,
        seed: u64,
        f: impl Fn(f64) -> [f64; 2],
    ) -> (Track, Manoeuvres) {
        use rand_distr::{Distribution, Normal};
        let cfg = ReplayConfig::default();
        let noise = Normal::new(0.0, sigma_m).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (mut t, mut m) = (Track::default(), Manoeuvres::default());
        for k in 0..=(secs * hz) as usize {
            let ts = k as f64 / hz;
            let p = f(ts);
            let o = Observation {
                t_s: ts,
                p_m: [p[0] + noise.sample(&mut rng), p[1] + noise.sample(&mut rng)],
                alt_m: 50.0,
                radius_m: 10.0,
            };
            if let (_, Some(i)) = t.insert(o, 100.0, 0.0) {
                m.update(&t, i, &cfg);
            }
        }
        (t, m)
    }

    /// A smooth, non-repeating curve: a slalom whose bends tighten and whose speed varies,
    /// as a spline tour's between its waypoints.
    fn slalom(t: f64) -> [f64; 2] {
        [
            12.0 * t + 20.0 * (0.05 * t).sin(),
            60.0 * (0.08 * t + 0.0008 * t * t).sin(),
        ]
    }

    /// Mean distance to `truth` and the fraction within `r_m` of it, `s` seconds ahead.
    fn spread_at(p: &mut ReplayParticles, s: f64, truth: [f64; 2], r_m: f64) -> (f64, f64) {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let n = p.cur.len();
        let (mut x, mut y) = (vec![0.0; n], vec![0.0; n]);
        p.advance_to(s, &mut x, &mut y, &mut rng);
        let d: Vec<f64> = (0..n)
            .map(|i| (x[i] - truth[0]).hypot(y[i] - truth[1]))
            .collect();
        (
            d.iter().sum::<f64>() / n as f64,
            d.iter().filter(|&&v| v <= r_m).count() as f64 / n as f64,
        )
    }

    #[test]
    fn a_quadratic_is_fitted_exactly() {
        let obs: Vec<Observation> = (0..50)
            .map(|k| {
                let t = f64::from(k) * 0.2;
                Observation {
                    t_s: t,
                    p_m: [3.0 + 2.0 * t - 0.5 * t * t, -1.0 + 0.25 * t * t],
                    alt_m: 0.0,
                    radius_m: 5.0,
                }
            })
            .collect();
        let q = quad_at(&obs, 49, 8.0, 0.5).expect("a fit");
        for u in [-4.0, 0.0, 3.0, 10.0] {
            let t = 9.8 + u;
            let p = q.at(u);
            assert!(
                (p[0] - (3.0 + 2.0 * t - 0.5 * t * t)).abs() < 1e-6,
                "{u}: {p:?}"
            );
            assert!((p[1] - (-1.0 + 0.25 * t * t)).abs() < 1e-6, "{u}: {p:?}");
        }
        // fewer than 6 observations or less than 3/4 of the window: no fit
        assert!(quad_at(&obs, 4, 8.0, 0.5).is_none());
        assert!(quad_at(&obs, 20, 8.0, 0.5).is_none());
    }

    #[test]
    fn a_smooth_curve_is_extrapolated_closer_than_its_replay_and_still_covered() {
        // 60 s of a slalom seen at 5 Hz with 1 m of noise: the past holds bends of other
        // curvatures and speeds than the present one, so replay alone spreads wide.
        let (t, m) = noisy_track(60.0, 5.0, 1.0, 11, slalom);
        let novel = Novel {
            speed_mps: 13.0,
            w_max_radps: 0.3,
            decision_interval_s: 1.0,
        };
        let run = |cfg: ReplayConfig, s: f64| {
            let mut rng = ChaCha8Rng::seed_from_u64(4);
            let mut p = ReplayParticles::new(&t, &m, &cfg, novel, 400, &mut rng).unwrap();
            let on = p.now_quad.is_some();
            let truth = slalom(60.0 + s);
            (on, spread_at(&mut p, s, truth, 3.0 + 1.5 * s))
        };
        let smooth = ReplayConfig::default();
        let plain = ReplayConfig {
            smooth_window_s: 0.0,
            ..smooth
        };
        for s in [3.0, 5.0, 10.0] {
            let (on, (d_smooth, near_smooth)) = run(smooth, s);
            let (off, (d_plain, _)) = run(plain, s);
            assert!(on && !off);
            // closer on average by a third at least
            assert!(
                d_smooth < 0.67 * d_plain,
                "+{s} s: {d_smooth} against {d_plain}"
            );
            // and the truth inside the cloud, not beside it (measured: 42%, 23% and 10% of
            // the particles within 7.5, 10.5 and 18 m; mean distance 9, 19 and 55 m against
            // 18, 38 and 108 m)
            assert!(near_smooth > 0.05, "+{s} s: {near_smooth}");
        }
    }

    #[test]
    fn a_random_turner_keeps_plain_replay() {
        // Turn rate redrawn every second uniformly within +-0.35 rad/s at 12 m/s: a quadratic
        // fitted to its last seconds says nothing of the next ones.
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let (mut p, mut h) = ([0.0f64, 0.0f64], 0.0f64);
        let mut path = vec![p];
        let mut w = 0.0;
        for k in 0..(120 * 50) {
            if k % 50 == 0 {
                w = (2.0 * unit(&mut rng) - 1.0) * 0.35;
            }
            h += w * 0.02;
            p = [p[0] + 12.0 * h.cos() * 0.02, p[1] + 12.0 * h.sin() * 0.02];
            path.push(p);
        }
        let f = |t: f64| path[((t * 50.0).round() as usize).min(path.len() - 1)];
        let (t, m) = noisy_track(120.0, 5.0, 1.0, 12, f);
        let cfg = ReplayConfig::default();
        let novel = Novel {
            speed_mps: 12.0,
            w_max_radps: 0.35,
            decision_interval_s: 1.0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let p = ReplayParticles::new(&t, &m, &cfg, novel, 64, &mut rng).unwrap();
        assert!(p.now_quad.is_none());
    }

    #[test]
    fn a_turn_under_way_is_replayed_as_a_turn() {
        // 15 m/s on a 34 s cycle: 11 s straight, 6 s turning left at 0.3 rad/s, 11 s
        // straight, 6 s turning right. Watched to 2 s into a left turn, which goes on for
        // 4 s more: the turn the obstacle is flying now says which stretches of its past
        // come next. Most of its past is straight flight, so anchors drawn uniformly mostly
        // fly on straight.
        let turn = |t: f64| match t % 34.0 {
            c if (11.0..17.0).contains(&c) => 0.3,
            c if c >= 28.0 => -0.3,
            _ => 0.0,
        };
        let (mut p, mut h) = ([0.0f64, 0.0f64], 0.0f64);
        let mut path = vec![p];
        for k in 0..(130 * 50) {
            h += turn(f64::from(k) * 0.02) * 0.02;
            p = [p[0] + 15.0 * h.cos() * 0.02, p[1] + 15.0 * h.sin() * 0.02];
            path.push(p);
        }
        let f = |t: f64| path[((t * 50.0).round() as usize).min(path.len() - 1)];
        let now = 3.0 * 34.0 + 11.0 + 2.0;
        let (t, m) = noisy_track(now, 5.0, 0.1, 5, f);
        let novel = Novel {
            speed_mps: 15.0,
            w_max_radps: 0.3,
            decision_interval_s: 1.0,
        };
        let within = |turn_share: f64, s: f64| {
            let cfg = ReplayConfig {
                turn_share,
                ..ReplayConfig::default()
            };
            let mut rng = ChaCha8Rng::seed_from_u64(8);
            let mut p = ReplayParticles::new(&t, &m, &cfg, novel, 400, &mut rng).unwrap();
            spread_at(&mut p, s, f(now + s), 5.0)
        };
        // Measured: within 5 m of the truth at +2 / +3 / +4 s, 12 / 9 / 7% of the particles
        // with uniform anchors, 36 / 27 / 17% with half drawn by the turn (the default),
        // 61 / 45 / 29% with all; mean distance 17.6 / 32.2 / 49.9 m, 11.3 / 21.6 / 35.0 m,
        // 5.4 / 11.6 / 20.9 m.
        for s in [2.0, 3.0, 4.0] {
            let (d0, c0) = within(0.0, s);
            let (d5, c5) = within(ReplayConfig::default().turn_share, s);
            let (d1, c1) = within(1.0, s);
            let msg = format!(
                "+{s} s: uniform {d0:.1} m {c0:.2}, half {d5:.1} m {c5:.2}, all {d1:.1} m {c1:.2}"
            );
            assert!(c5 >= 2.0 * c0 && c5 >= 0.15, "{msg}");
            assert!(d5 < 0.8 * d0, "{msg}");
            assert!(c1 > c5 && d1 < d5, "{msg}");
        }
    }

    #[test]
    fn a_noise_free_constant_turn_is_replayed_onto_its_own_continuation() {
        // 10 m/s on a 0.1 rad/s circle: every stretch of the past is the same arc, so every
        // particle, chained or not, lands on the true continuation.
        let (w, v) = (0.1, 10.0);
        let (t, m) = circle_track(60.0, 5.0, w, v);
        let cfg = ReplayConfig {
            novelty: false,
            ..ReplayConfig::default()
        };
        assert!(m.ready(&t, &cfg));
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let still = Novel {
            speed_mps: v,
            w_max_radps: 0.0,
            decision_interval_s: 1.0,
        };
        let mut p = ReplayParticles::new(&t, &m, &cfg, still, 64, &mut rng).expect("anchors");
        let (mut x, mut y) = (vec![0.0; 64], vec![0.0; 64]);
        for s in [1.0, 5.0, 20.0, 90.0] {
            p.advance_to(s, &mut x, &mut y, &mut rng);
            let a = w * (60.0 + s);
            let truth = [v / w * a.sin(), v / w * (1.0 - a.cos())];
            for i in 0..64 {
                let d = (x[i] - truth[0]).hypot(y[i] - truth[1]);
                // The frames' fit lag cancels between frames fitted over a whole window;
                // those of the track's first seconds fit a shorter one, whose lag differs
                // (up to 4% of the distance flown, measured: 0.4 m at 1 s, 2 m at 5 s,
                // 6.7 m at 20 s, 9.1 m at 90 s).
                assert!(d < 1.0 + 0.04 * v * s, "{s}: {d}");
            }
        }
    }

    #[test]
    fn an_out_of_order_observation_gives_the_frames_of_an_in_order_track() {
        let cfg = ReplayConfig::default();
        let pts: Vec<Observation> = (0..60)
            .map(|i| {
                let t = f64::from(i) * 0.5;
                Observation {
                    t_s: t,
                    p_m: [8.0 * t, (0.3 * t).sin() * 20.0],
                    alt_m: 0.0,
                    radius_m: 5.0,
                }
            })
            .collect();
        let run = |order: &[usize]| {
            let (mut t, mut m) = (Track::default(), Manoeuvres::default());
            for &i in order {
                if let (_, Some(idx)) = t.insert(pts[i], 100.0, 0.0) {
                    m.update(&t, idx, &cfg);
                }
            }
            m.frames().to_vec()
        };
        let in_order: Vec<usize> = (0..60).collect();
        let mut late = in_order.clone();
        late.swap(30, 33);
        late.swap(10, 11);
        assert_eq!(run(&in_order), run(&late));
    }

    #[test]
    fn a_short_or_slow_track_is_not_ready() {
        let cfg = ReplayConfig::default();
        let (t, m) = circle_track(10.0, 5.0, 0.1, 10.0);
        assert!(!m.ready(&t, &cfg));
        let (mut t, mut m) = (Track::default(), Manoeuvres::default());
        for k in 0..200 {
            let o = Observation {
                t_s: f64::from(k) * 0.5,
                p_m: [0.0, 0.0],
                alt_m: 0.0,
                radius_m: 5.0,
            };
            if let (_, Some(i)) = t.insert(o, 100.0, 0.0) {
                m.update(&t, i, &cfg);
            }
        }
        assert!(!m.ready(&t, &cfg));
    }

    #[test]
    fn novelty_spreads_a_short_watch_more_than_a_long_one() {
        // The same circle watched 30 s and 300 s: 20 s ahead, the short watch's particles
        // have more often left the replay (rate 1/30 against 1/300) and spread wider.
        let (w, v) = (0.02, 10.0);
        let cfg = ReplayConfig::default();
        let novel = Novel {
            speed_mps: v,
            w_max_radps: 0.3,
            decision_interval_s: 1.0,
        };
        let spread = |secs: f64| {
            let (t, m) = circle_track(secs, 5.0, w, v);
            let mut rng = ChaCha8Rng::seed_from_u64(5);
            let n = 400;
            let mut p = ReplayParticles::new(&t, &m, &cfg, novel, n, &mut rng).unwrap();
            let (mut x, mut y) = (vec![0.0; n], vec![0.0; n]);
            p.advance_to(20.0, &mut x, &mut y, &mut rng);
            let a = w * (secs + 20.0);
            let truth = [v / w * a.sin(), v / w * (1.0 - a.cos())];
            let far = (0..n)
                .filter(|&i| (x[i] - truth[0]).hypot(y[i] - truth[1]) > 10.0)
                .count();
            far as f64 / n as f64
        };
        let (short, long) = (spread(30.0), spread(300.0));
        assert!(
            short > 0.25 && long < 0.12 && short > 2.0 * long,
            "{short} {long}"
        );
    }
}
