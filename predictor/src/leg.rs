//! A spline tour's present leg: the judges' server flies each sphere round a periodic
//! spline through its waypoints, each axis a cubic in time between two waypoints (a knot),
//! so until the next knot the sphere's future is the cubic its leg so far fits exactly
//! (issue 10, "prediction that exploits how obstacles really move"; `sim::spline`).
//!
//! [`fit`] fits a cubic in time to the longest recent stretch of the track one cubic
//! explains within the feed's noise (the residual variance of cubics over consecutive 4 s
//! pieces of the last 40 s, pooled): going back from the newest observation, the stretch
//! ends where the fit's residual variance exceeds the noise's by more than three standard
//! errors of their ratio, which is where the previous leg's cubic begins to show. The leg
//! is trusted from [`ReplayConfig::leg_min_s`] on, and only from a precise feed
//! ([`ReplayConfig::leg_max_noise_m`]): within a noisy one's residuals a random or biased
//! turner fits a cubic too, and half its particles flown on that cubic were measured
//! (prediction report, 1 m noise at 2 Hz) to cost turners 0.3-2 nats.
//!
//! The next knot is not predictable from the leg (its end is where the next waypoint is,
//! unseen): each particle leaves the cubic at its own knot time, no sooner than the
//! tour's shortest leg ([`ReplayConfig::leg_min_length_m`] at the present speed, less what
//! the leg has flown) plus an exponential time of mean [`ReplayConfig::leg_knot_mean_s`],
//! and from there flies on as the stage model does. Its coefficients are drawn from the
//! fit's covariance (the residual variance, at least 1 cm per axis, times `(X^T X)^-1`).
//! [`ReplayConfig::leg_share`] of the particles fly the leg; the others fly the model's
//! own prediction (replay, the young quadratic or the stage model), which keeps what a
//! wrong leg would miss covered.
//!
//! # Units
//! ENU metres, seconds.

use crate::replay::ReplayConfig;
use crate::track::{Observation, Track};
use crate::young::{Knot, YoungModel};

/// Longest a particle flies a leg's cubic, seconds: legs are shorter, and a cubic flown
/// further runs away.
pub const LEG_MAX_S: f64 = 30.0;

/// Residual variance per axis of cubics fitted to consecutive `piece_s` pieces of the last
/// `span_s` of `obs`, pooled, and its degrees of freedom; `None` without a piece of 8
/// observations.
fn pooled_noise(obs: &[Observation], piece_s: f64, span_s: f64) -> Option<(f64, f64)> {
    let last = obs.last()?.t_s;
    let (mut rss, mut dof) = (0.0, 0.0);
    let mut end = obs.len();
    while end > 0 && last - obs[end - 1].t_s < span_s {
        let t_end = obs[end - 1].t_s;
        let start = obs[..end].partition_point(|o| o.t_s <= t_end - piece_s);
        let piece = &obs[start..end];
        if piece.len() >= 8 {
            let t0 = piece[piece.len() - 1].t_s;
            let mut a = nalgebra::Matrix4::<f64>::zeros();
            let (mut bx, mut by) = (nalgebra::Vector4::zeros(), nalgebra::Vector4::zeros());
            for o in piece {
                let u = (o.t_s - t0) / piece_s;
                let row = nalgebra::Vector4::new(1.0, u, u * u, u * u * u);
                a += row * row.transpose();
                bx += row * (o.p_m[0] - piece[0].p_m[0]);
                by += row * (o.p_m[1] - piece[0].p_m[1]);
            }
            if let Some(inv) = a.try_inverse() {
                let (cx, cy) = (inv * bx, inv * by);
                for o in piece {
                    let u = (o.t_s - t0) / piece_s;
                    let row = nalgebra::Vector4::new(1.0, u, u * u, u * u * u);
                    rss += (o.p_m[0] - piece[0].p_m[0] - row.dot(&cx)).powi(2)
                        + (o.p_m[1] - piece[0].p_m[1] - row.dot(&cy)).powi(2);
                }
                dof += (2 * (piece.len() - 4)) as f64;
            }
        }
        if start == 0 {
            break;
        }
        end = start;
    }
    (dof > 0.0).then(|| (rss / dof, dof))
}

/// A spline tour's present leg: the cubic in time through the longest recent stretch of
/// the track that one cubic fits to within its noise. Returns the model and the stretch's
/// length, seconds.
pub fn fit(track: &Track, cfg: &ReplayConfig, speed_mps: f64) -> Option<(YoungModel, f64)> {
    if cfg.leg_share <= 0.0 {
        return None;
    }
    const SCALE: f64 = 30.0;
    const MIN_WINDOW_S: f64 = 4.0;
    const MAX_WINDOW_S: f64 = 120.0;
    const FLOOR_M: f64 = 0.01;
    let obs = track.observations();
    let last = obs.last()?;
    // Running sums from the newest observation back: powers of s = u / SCALE, moments.
    let mut pw = [0.0f64; 7];
    let mut bx = [0.0f64; 4];
    let mut by = [0.0f64; 4];
    let mut yy = 0.0;
    let solve = |pw: &[f64; 7], bx: &[f64; 4], by: &[f64; 4], yy: f64| {
        let a = nalgebra::Matrix4::<f64>::from_fn(|r, k| pw[r + k]);
        let inv = a.try_inverse()?;
        let vx = nalgebra::Vector4::from_column_slice(bx);
        let vy = nalgebra::Vector4::from_column_slice(by);
        let (cx, cy) = (inv * vx, inv * vy);
        let rss = (yy - cx.dot(&vx) - cy.dot(&vy)).max(0.0);
        Some((inv, cx, cy, rss))
    };
    // The observations' noise: residuals of cubics fitted to consecutive 4 s pieces of the
    // last 40 s, pooled (a knot inside a piece barely shows in 4 s).
    let noise = pooled_noise(obs, 4.0, 40.0).map(|(v, d)| (v.max(FLOOR_M * FLOOR_M), d));
    // A noisy feed hides a turner's turns within a cubic's residuals: legs only from a
    // precise one.
    let (v0, d0) = noise.filter(|(v, _)| *v <= cfg.leg_max_noise_m * cfg.leg_max_noise_m)?;
    let mut best = None;
    let mut n = 0usize;
    for o in obs.iter().rev() {
        let u = o.t_s - last.t_s;
        if -u > MAX_WINDOW_S {
            break;
        }
        let sc = u / SCALE;
        let (x, y) = (o.p_m[0] - last.p_m[0], o.p_m[1] - last.p_m[1]);
        let mut p = 1.0;
        for (k, w) in pw.iter_mut().enumerate() {
            *w += p;
            if k < 4 {
                bx[k] += p * x;
                by[k] += p * y;
            }
            p *= sc;
        }
        yy += x * x + y * y;
        n += 1;
        if n < 8 || -u < MIN_WINDOW_S {
            continue;
        }
        let Some((inv, cx, cy, rss)) = solve(&pw, &bx, &by, yy) else {
            continue;
        };
        let dof = (2 * (n - 4)) as f64;
        let var = rss / dof;
        // One cubic fits while its residuals are the noise's (a z-test of the variance ratio).
        if var > v0 * (1.0 + 3.0 * (2.0 / dof + 2.0 / d0).sqrt()) {
            break;
        }
        best = Some((inv, cx, cy, var, -u));
    }
    let (inv, cx, cy, var, window) = best?;
    if window < cfg.leg_min_s {
        return None;
    }
    let var = var.max(FLOOR_M * FLOOR_M);
    let s = [
        1.0,
        1.0 / SCALE,
        1.0 / (SCALE * SCALE),
        1.0 / (SCALE * SCALE * SCALE),
    ];
    let mut cov = nalgebra::Matrix4::<f64>::zeros();
    for r in 0..4 {
        for k in 0..4 {
            cov[(r, k)] = var * inv[(r, k)] * s[r] * s[k];
        }
    }
    let chol = cov.cholesky()?;
    let lm = chol.l();
    let l = std::array::from_fn(|r| std::array::from_fn(|k| lm[(r, k)]));
    let c = [
        [
            last.p_m[0] + cx[0],
            cx[1] * s[1],
            cx[2] * s[2],
            cx[3] * s[3],
        ],
        [
            last.p_m[1] + cy[0],
            cy[1] * s[1],
            cy[2] * s[2],
            cy[3] * s[3],
        ],
    ];
    let until_s = LEG_MAX_S;
    let v_fit = |u: f64| {
        let d = |a: usize| c[a][1] + u * (2.0 * c[a][2] + 3.0 * u * c[a][3]);
        d(0).hypot(d(1))
    };
    let v_now = v_fit(0.0);
    let mean_s = cfg.leg_knot_mean_s;
    let min_s = (cfg.leg_min_length_m / v_now.max(1.0) - window).max(0.0);
    let horizon = (min_s + 3.0 * mean_s).min(until_s);
    let v_top = (0..=horizon.ceil() as usize)
        .map(|k| v_fit(k as f64))
        .fold(speed_mps.max(v_now), f64::max);
    let max_speed_mps = 1.5 * v_top + 2.0;
    Some((
        YoungModel {
            c,
            l,
            jerk_sigma_mps3: 0.0,
            until_s,
            max_speed_mps,
            share: cfg.leg_share,
            knot: Some(Knot { min_s, mean_s }),
        },
        window,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Predictor, PredictorConfig};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// Two legs of a tour joined at a knot at t = 20 s: position, velocity and acceleration
    /// continuous there, the jerk changing (as the judges' splines do).
    fn two_legs(t: f64) -> [f64; 2] {
        let a = |t: f64| {
            [
                12.0 * t + 0.05 * t * t - 0.004 * t * t * t,
                3.0 * t + 0.08 * t * t + 0.002 * t * t * t,
            ]
        };
        if t <= 20.0 {
            return a(t);
        }
        let (p, v, acc) = (
            a(20.0),
            [
                12.0 + 0.1 * 20.0 - 0.012 * 400.0,
                3.0 + 0.16 * 20.0 + 0.006 * 400.0,
            ],
            [0.1 - 0.024 * 20.0, 0.16 + 0.012 * 20.0],
        );
        let j = [0.03, -0.04];
        let u = t - 20.0;
        std::array::from_fn(|k| p[k] + v[k] * u + 0.5 * acc[k] * u * u + j[k] * u * u * u / 6.0)
    }

    fn track(noise_m: f64, until_s: f64, seed: u64) -> Track {
        let n = Normal::new(0.0, noise_m.max(1e-12)).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut tr = Track::default();
        for k in 0..=(until_s * 5.0) as usize {
            let t = k as f64 / 5.0;
            let mut p = two_legs(t);
            if noise_m > 0.0 {
                p[0] += n.sample(&mut rng);
                p[1] += n.sample(&mut rng);
            }
            let o = Observation {
                t_s: t,
                p_m: p,
                alt_m: 50.0,
                radius_m: 10.0,
            };
            tr.insert(o, 50.0, 0.0);
        }
        tr
    }

    #[test]
    fn a_leg_is_fitted_back_to_its_knot_and_flown_exactly() {
        let cfg = ReplayConfig::default();
        let (leg, window) = fit(&track(0.0, 35.0, 0), &cfg, 15.0).expect("an exact feed");
        // The leg began at the knot, 15 s before the newest observation (the first seconds
        // of the previous leg differ from its cubic by millimetres).
        assert!((15.0..=18.0).contains(&window), "{window}");
        // Its cubic is the second leg's: within decimetres 5 s ahead, a metre 10 s ahead.
        for (u, tol) in [(0.0, 0.05), (5.0, 0.3), (10.0, 1.0)] {
            let (p, want) = (leg.at(u), two_legs(35.0 + u));
            assert!(geom::dist(p, want) < tol, "+{u} s: {p:?} against {want:?}");
        }
        // No knot before the tour's shortest leg (100 m at the present speed) is flown.
        let k = leg.knot.expect("a leg has knots");
        let v = leg.c[0][1].hypot(leg.c[1][1]);
        assert!(
            (k.min_s - (100.0 / v - window).max(0.0)).abs() < 1e-9,
            "{k:?}"
        );
        assert_eq!(k.mean_s, cfg.leg_knot_mean_s);
        // Off, too short, or a noisy feed: no leg.
        let off = ReplayConfig {
            leg_share: 0.0,
            ..cfg
        };
        assert!(fit(&track(0.0, 35.0, 0), &off, 15.0).is_none());
        assert!(
            fit(&track(0.0, 7.0, 0), &cfg, 15.0).is_none(),
            "7 s of flight"
        );
        assert!(
            fit(&track(1.0, 35.0, 1), &cfg, 15.0).is_none(),
            "1 m of noise"
        );
        // A little noise (0.1 m) still gives the leg, about as long.
        let (_, w) = fit(&track(0.1, 35.0, 2), &cfg, 15.0).expect("0.1 m of noise");
        assert!((10.0..=20.0).contains(&w), "{w}");
    }

    /// Half the particles fly the leg to their knot (an exponential time of mean
    /// `leg_knot_mean_s` here, the leg being longer than the shortest); the prediction
    /// stays within the model's reach (the threat filter's bound).
    #[test]
    fn half_the_particles_fly_the_leg_within_the_models_reach() {
        let predictor = |cfg: PredictorConfig| {
            let mut p = Predictor::new(cfg);
            for o in track(0.0, 35.0, 0).observations() {
                p.observe("0", *o);
            }
            p
        };
        let with = predictor(PredictorConfig::default());
        let mut off = PredictorConfig::default();
        off.replay = off.replay.map(|r| ReplayConfig {
            leg_share: 0.0,
            ..r
        });
        let without = predictor(off);
        let model = with.model("0").unwrap().clone();
        assert!(model.leg.is_some(), "{model:?}");
        assert!(without.model("0").unwrap().leg.is_none());
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for h in [1.0, 3.0, 5.0, 10.0, 20.0, 30.0, 45.0] {
            let r = model.reach_m(h);
            let s = with.sample_future("0", h, 400, &mut rng).unwrap();
            for q in &s {
                let d = geom::dist(*q, model.position_m);
                assert!(d <= r + 1e-9, "+{h} s: {d} > {r}");
            }
            if (3.0..=10.0).contains(&h) {
                let truth = two_legs(35.0 + h);
                let near =
                    |s: &[[f64; 2]]| s.iter().filter(|q| geom::dist(**q, truth) < 2.0).count();
                let s0 = without.sample_future("0", h, 400, &mut rng).unwrap();
                let (n1, n0) = (near(&s), near(&s0));
                let on_leg = 200.0 * (-h / 20.0f64).exp();
                assert!(
                    n1 as f64 >= 0.85 * on_leg && n1 >= n0 + 50,
                    "+{h} s: {n1} against {n0}"
                );
            }
        }
    }
}
