//! A young track's future: the quadratic in time through its last seconds, with the
//! uncertainty of that fit (issue 10, "Prediction in a track's first half-minute").
//!
//! Until a track holds [`ReplayConfig::min_history_s`] of flight, replay has too few of its
//! own stretches to draw from, and the stage models fly the present speed with turns drawn
//! afresh every decision interval: a random walk of the heading, which cannot follow a
//! sustained turn (a spline tour's bend, a biased turner) nor a change of speed (a tour
//! sphere leaving its turn-back). The prediction report measured that as 47-72% coverage of
//! the 95% region at +20 s in a track's first half-minute.
//!
//! Half of a young track's particles ([`ReplayConfig::young_share`]) instead fly the
//! least-squares quadratic through its last [`ReplayConfig::smooth_window_s`] (or all of it,
//! when shorter), which carries the present speed, turn and change of speed, for
//! [`ReplayConfig::young_horizon_s`]; each particle's coefficients are drawn from the fit's
//! own covariance (the residuals' variance times `(X^T X)^-1`: observation noise and the
//! fit's error, larger for a shorter watch), plus a random jerk
//! ([`ReplayConfig::young_jerk_mps3`], what a quadratic leaves out). From there each flies on
//! at its own speed and heading, turning as the stage model does. The other half fly the
//! stage model from the start: a random turner's quadratic over a few seconds is a poor
//! guess of its next ones, and the mixture covers what either half covers (all of them on
//! the quadratic: 60-66% coverage at +5 s for random, biased and patterned turners; the
//! mixture 94-96%).
//!
//! An obstacle at rest (fitted speed 0) is given a quadratic only when its acceleration is
//! clearly not noise: a turn-back speeding up again, never a stationary sphere.
//!
//! The stage model a young track's particles turn by draws its turns about zero, so a track
//! that has leaned one way all its short life (a biased turner) is predicted to stop
//! leaning once its quadratic runs out: 55% coverage of the 95% region at +20 s in the
//! prediction report with the judges' feed. With [`ReplayConfig::young_bias_se`] above 0
//! (off by default; measured in the README, "A young track's lean") its turns are drawn
//! about its shown bias instead ([`turn_bias_radps`]: the mean of its turn samples less
//! that many standard errors, 0 when the mean is within them), so a random turner, whose
//! mean is noise, is predicted as before.
//!
//! # Units
//! ENU metres, seconds, radians.

use crate::replay::ReplayConfig;
use crate::track::Track;
use nalgebra::{Matrix3, Vector3};

/// The fitted quadratic of a young track and how its particles fly it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct YoungModel {
    /// `[x, y]` coefficients of `1, u, u^2, u^3`, `u` seconds after the newest observation
    /// (the cubic term 0 for a young quadratic).
    pub c: [[f64; 4]; 2],
    /// Lower-triangular factor `L` of the coefficients' covariance (`L L^T`, the same for
    /// both axes), metres and seconds (the last row and column 0 for a young quadratic).
    pub l: [[f64; 4]; 4],
    /// A leg's end: each particle leaves the cubic after `min_s` plus an exponential time
    /// of mean `mean_s` (at most `until_s`); `None`: every particle at `until_s`.
    pub knot: Option<Knot>,
    /// Standard deviation of each particle's jerk per axis, m/s^3.
    pub jerk_sigma_mps3: f64,
    /// How long particles fly the quadratic, seconds.
    pub until_s: f64,
    /// The fastest a particle flies and the bound of its reach, m/s.
    pub max_speed_mps: f64,
    /// Share of the particles that fly the quadratic; the others fly the stage model.
    pub share: f64,
}

impl YoungModel {
    /// How far a particle can be from the fitted position `dt_s` after the newest
    /// observation, metres: what the particles are clamped to.
    pub fn reach_m(&self, dt_s: f64) -> f64 {
        self.max_speed_mps * dt_s.max(0.0) + self.slack_m()
    }

    /// The start's allowance in a particle's reach: four standard deviations of the
    /// fitted position, at least 5 m.
    pub fn slack_m(&self) -> f64 {
        (4.0 * self.l[0][0]).max(5.0)
    }

    /// The mean position `u` seconds after the newest observation.
    pub fn at(&self, u: f64) -> [f64; 2] {
        let [x, y] = self.c;
        [
            x[0] + u * (x[1] + u * (x[2] + u * x[3])),
            y[0] + u * (y[1] + u * (y[2] + u * y[3])),
        ]
    }
}

/// A young track's shown turn bias, rad/s (counter-clockwise positive): the mean of its
/// turn samples less [`ReplayConfig::young_bias_se`] standard errors of that mean (0 when
/// the mean is within them, or with fewer than 3 samples). The stage model adds it to every
/// turn it draws, so a track that has turned one way for all its short life is predicted to
/// go on turning that way, while a random turner's mean, within its own noise, adds nothing.
pub fn turn_bias_radps(samples: &[crate::estimate::TurnSample], cfg: &ReplayConfig) -> f64 {
    let n = samples.len();
    if cfg.young_bias_se <= 0.0 || n < 3 {
        return 0.0;
    }
    let nf = n as f64;
    let mean = samples.iter().map(|s| s.omega_radps).sum::<f64>() / nf;
    let var = samples
        .iter()
        .map(|s| (s.omega_radps - mean).powi(2))
        .sum::<f64>()
        / (nf - 1.0);
    let se = (var / nf).sqrt();
    mean.signum() * (mean.abs() - cfg.young_bias_se * se).max(0.0)
}

/// When a leg of a spline tour ends (a knot, where the cubic changes), seconds after the
/// newest observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knot {
    /// No knot before this.
    pub min_s: f64,
    /// Mean of the exponential time after `min_s`.
    pub mean_s: f64,
}

/// Fits a young track's quadratic (the caller decides whether the track is young);
/// `None` when it spans less than [`ReplayConfig::young_min_span_s`] in its window, holds
/// fewer than 6 observations there, `young_horizon_s` is 0, or the obstacle is at rest
/// (`speed_mps` 0) without a clear acceleration.
pub fn fit(track: &Track, cfg: &ReplayConfig, speed_mps: f64) -> Option<YoungModel> {
    if cfg.young_horizon_s <= 0.0 {
        return None;
    }
    let obs = track.observations();
    let last = obs.last()?;
    let from =
        obs.partition_point(|o| o.t_s < last.t_s - cfg.smooth_window_s.max(cfg.young_min_span_s));
    let win = &obs[from..];
    let span = last.t_s - win[0].t_s;
    if win.len() < 6 || span < cfg.young_min_span_s {
        return None;
    }
    // Normal equations on u / span (conditioning).
    let sc = 1.0 / span;
    let mut ata = Matrix3::<f64>::zeros();
    let (mut bx, mut by) = (Vector3::<f64>::zeros(), Vector3::<f64>::zeros());
    for o in win {
        let u = (o.t_s - last.t_s) * sc;
        let row = Vector3::new(1.0, u, u * u);
        ata += row * row.transpose();
        bx += row * o.p_m[0];
        by += row * o.p_m[1];
    }
    let inv = ata.try_inverse()?;
    let (cx, cy) = (inv * bx, inv * by);
    let mut rss = 0.0;
    for o in win {
        let u = (o.t_s - last.t_s) * sc;
        let px = cx[0] + u * (cx[1] + u * cx[2]);
        let py = cy[0] + u * (cy[1] + u * cy[2]);
        rss += (o.p_m[0] - px).powi(2) + (o.p_m[1] - py).powi(2);
    }
    let dof = (2 * (win.len() - 3)) as f64;
    let var = (rss / dof).max(cfg.young_noise_floor_m.powi(2));
    // Back to seconds: coefficient k scales by sc^k.
    let s = [1.0, sc, sc * sc];
    let mut cov = Matrix3::<f64>::zeros();
    for r in 0..3 {
        for k in 0..3 {
            cov[(r, k)] = var * inv[(r, k)] * s[r] * s[k];
        }
    }
    let chol = cov.cholesky()?;
    let lm = chol.l();
    let l: [[f64; 4]; 4] = std::array::from_fn(|r| {
        std::array::from_fn(|k| if r < 3 && k < 3 { lm[(r, k)] } else { 0.0 })
    });
    let c = [
        [cx[0], cx[1] * s[1], cx[2] * s[2], 0.0],
        [cy[0], cy[1] * s[1], cy[2] * s[2], 0.0],
    ];
    // An obstacle at rest (the estimate's speed 0) moves on only when its fitted
    // acceleration is clearly not noise (chi-square, 2 degrees of freedom, p < 0.001): a
    // turn-back speeding up again, not a stationary sphere's noise.
    let var_a: f64 = l[2].iter().map(|v| v * v).sum();
    let chi2 = (c[0][2].powi(2) + c[1][2].powi(2)) / var_a;
    // (A NaN statistic, no acceleration at all, is not clear either.)
    if speed_mps <= 0.0 && (chi2.is_nan() || chi2 <= 13.8) {
        return None;
    }
    let until_s = cfg.young_horizon_s;
    // Speeds along the fitted quadratic (its speed is convex in time: the ends bound it).
    let v_fit = |u: f64| (c[0][1] + 2.0 * c[0][2] * u).hypot(c[1][1] + 2.0 * c[1][2] * u);
    let v_top = v_fit(0.0).max(v_fit(until_s)).max(speed_mps);
    // Generous: the fit's top speed with room for its error.
    let max_speed_mps = 1.5 * v_top + 2.0;
    Some(YoungModel {
        c,
        l,
        jerk_sigma_mps3: cfg.young_jerk_mps3,
        until_s,
        max_speed_mps,
        share: cfg.young_share,
        knot: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::Observation;
    use crate::{Predictor, PredictorConfig};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    fn track(f: impl Fn(f64) -> [f64; 2], from: f64, secs: f64, hz: f64) -> Vec<Observation> {
        (0..=(secs * hz) as usize)
            .map(|k| {
                let t = from + k as f64 / hz;
                Observation {
                    t_s: t,
                    p_m: f(t),
                    alt_m: 50.0,
                    radius_m: 10.0,
                }
            })
            .collect()
    }

    #[test]
    fn a_noise_free_quadratic_is_fitted_exactly_with_the_floor_spread() {
        let f = |t: f64| [3.0 + 2.0 * t + 0.25 * t * t, -1.0 - 4.0 * t + 0.1 * t * t];
        let mut tr = Track::default();
        for o in track(f, 0.0, 6.0, 5.0) {
            tr.insert(o, 50.0, 0.0);
        }
        let y = fit(&tr, &ReplayConfig::default(), 0.0).expect("6 s at 5 Hz");
        // About the newest observation (t = 6): value, slope and curvature.
        let want = [
            [3.0 + 12.0 + 9.0, 2.0 + 3.0, 0.25],
            [-1.0 - 24.0 + 3.6, -4.0 + 1.2, 0.1],
        ];
        for a in 0..2 {
            for k in 0..3 {
                assert!((y.c[a][k] - want[a][k]).abs() < 1e-6, "{:?}", y.c);
            }
        }
        // No residuals: the spread is the floor's (0.5 m) through the fit's leverage, a
        // fraction of a metre at the newest observation.
        assert!(y.l[0][0] > 0.1 && y.l[0][0] < 0.5, "{:?}", y.l);
        // Too short a watch, or the young stage turned off: no quadratic.
        let mut short = Track::default();
        for o in track(f, 0.0, 1.5, 5.0) {
            short.insert(o, 50.0, 0.0);
        }
        assert!(fit(&short, &ReplayConfig::default(), 0.0).is_none());
        let off = ReplayConfig {
            young_horizon_s: 0.0,
            ..ReplayConfig::default()
        };
        assert!(fit(&tr, &off, 0.0).is_none());
    }

    /// The shown bias is the samples' mean less `young_bias_se` (2 here) standard errors of
    /// it: a track leaning left at 0.1 rad/s gets most of it, a track whose mean is within
    /// its noise none, and fewer than three samples or `young_bias_se` 0 (the default) give
    /// none.
    #[test]
    fn a_turn_bias_is_the_mean_turn_less_two_standard_errors() {
        use crate::estimate::TurnSample;
        let samples = |w: &[f64]| -> Vec<TurnSample> {
            w.iter()
                .enumerate()
                .map(|(k, &omega_radps)| TurnSample {
                    k: k as i64,
                    omega_radps,
                    radius_m: 15.0 / omega_radps.abs().max(1e-9),
                    speed_mps: 15.0,
                })
                .collect()
        };
        let cfg = ReplayConfig {
            young_bias_se: 2.0,
            ..ReplayConfig::default()
        };
        // Mean 0.1, sample standard deviation 0.05 * sqrt(10 / 9), ten samples.
        let lean: Vec<f64> = (0..10)
            .map(|k| if k % 2 == 0 { 0.15 } else { 0.05 })
            .collect();
        let se = (0.05f64 * 0.05 * 10.0 / 9.0 / 10.0).sqrt();
        let b = turn_bias_radps(&samples(&lean), &cfg);
        assert!((b - (0.1 - 2.0 * se)).abs() < 1e-12, "{b}");
        // The mirror leans right by as much.
        let right: Vec<f64> = lean.iter().map(|w| -w).collect();
        assert!((turn_bias_radps(&samples(&right), &cfg) + b).abs() < 1e-12);
        // A zigzag about 0.02 with a spread of 0.3: the mean is within its noise.
        let zig: Vec<f64> = (0..10)
            .map(|k| if k % 2 == 0 { 0.32 } else { -0.28 })
            .collect();
        assert_eq!(turn_bias_radps(&samples(&zig), &cfg), 0.0);
        assert_eq!(turn_bias_radps(&samples(&lean[..2]), &cfg), 0.0);
        assert_eq!(
            turn_bias_radps(&samples(&lean), &ReplayConfig::default()),
            0.0
        );
    }

    /// The threat filter leaves an obstacle out when its reach (`MotionModel::reach_m`)
    /// cannot meet the route: every particle of a young track, noisy and speeding up,
    /// turning or starting from rest, stays within it at every horizon.
    #[test]
    fn young_particles_never_leave_the_models_reach() {
        let noise = Normal::new(0.0, 1.5).unwrap();
        let movers: [fn(f64) -> [f64; 2]; 3] = [
            |t| [0.4 * t * t, 0.0],
            |t| [200.0 * (0.08 * t).sin(), 200.0 * (1.0 - (0.08 * t).cos())],
            |t| [12.0 * t, 3.0 * t + 0.05 * t * t * t],
        ];
        for (m, f) in movers.iter().enumerate() {
            for seed in 0..5u64 {
                let mut p = Predictor::new(PredictorConfig::default());
                let mut nrng = ChaCha8Rng::seed_from_u64(seed);
                for mut o in track(f, 0.0, 3.0 + 3.0 * seed as f64, 2.0) {
                    o.p_m[0] += noise.sample(&mut nrng);
                    o.p_m[1] += noise.sample(&mut nrng);
                    p.observe("0", o);
                }
                let model = p.model("0").unwrap().clone();
                assert!(model.young.is_some(), "mover {m} seed {seed}: {model:?}");
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                for h in [0.5, 3.0, 10.0, 10.5, 30.0, 60.0] {
                    let r = model.reach_m(h);
                    for q in p.sample_future("0", h, 256, &mut rng).unwrap() {
                        let d = geom::dist(q, model.position_m);
                        assert!(d <= r + 1e-9, "mover {m} seed {seed} +{h} s: {d} > {r}");
                    }
                }
            }
        }
    }

    /// A sphere at rest at its turn-back (a fitted speed of 0) that is speeding up again:
    /// the stage model alone would keep it where it is; the young quadratic moves it on.
    #[test]
    fn a_young_track_at_rest_but_speeding_up_is_predicted_to_move() {
        // At rest at t = 4 (the newest observation), 1 m/s^2 either side of it.
        let f = |t: f64| [0.5 * (t - 4.0) * (t - 4.0), 0.0];
        let mut p = Predictor::new(PredictorConfig::default());
        for o in track(f, 0.0, 4.0, 5.0) {
            p.observe("0", o);
        }
        let model = p.model("0").unwrap();
        assert_eq!(model.speed_mps, 0.0, "{model:?}");
        assert!(model.young.is_some());
        let near = |p: &Predictor| {
            let mut rng = ChaCha8Rng::seed_from_u64(1);
            let s = p.sample_future("0", 5.0, 400, &mut rng).unwrap();
            s.iter()
                .filter(|q| (q[0] - 12.5).abs() < 10.0 && q[1].abs() < 10.0)
                .count()
        };
        // The quadratic's half of the particles is near x = 12.5 (0.5 * 5^2; about 4.5 m
        // per axis of spread from the residual floor and the jerk); the stage model's half
        // stays at the start.
        let n = near(&p);
        assert!(n >= 150, "{n} of 400 near the truth");
        let mut off = Predictor::new(PredictorConfig {
            replay: Some(ReplayConfig {
                young_horizon_s: 0.0,
                ..ReplayConfig::default()
            }),
            ..PredictorConfig::default()
        });
        for o in track(f, 0.0, 4.0, 5.0) {
            off.observe("0", o);
        }
        let n = near(&off);
        assert!(
            n < 40,
            "{n} of 400 near the truth without the young quadratic"
        );
        // A sphere at rest for good has no quadratic to fly (its acceleration is 0).
        let mut still = Predictor::new(PredictorConfig::default());
        for o in track(|_| [5.0, -3.0], 0.0, 4.0, 5.0) {
            still.observe("0", o);
        }
        assert!(still.model("0").unwrap().young.is_none());
    }
}
