//! Prediction report: how well each characterization stage (and constant-velocity
//! extrapolation) predicts where a moving obstacle will be, per behaviour.
//!
//! For every behaviour family, scenarios are drawn and their telemetry (the same noisy,
//! lossy streams the strategies see) is fed to a [`predictor::Predictor`] in time order. At
//! evaluation times every `eval_every_s` (after a `warmup_s`), for each horizon (+1, +3, +5,
//! +10, +20 s) and each method, the predicted distribution of the obstacle's horizontal position
//! is compared with the true position:
//! - stages 1-4 (forced) and the automatic stage: `n` positions sampled with
//!   `Predictor::sample_future_with_stage` (resp. `sample_future`); the density is a Gaussian
//!   kernel density over the samples (isotropic, Silverman bandwidth, at least
//!   [`MIN_BANDWIDTH_M`]);
//! - `auto_no_lap`: the automatic stage's scores again, counted only while no lap of the
//!   obstacle's tour is recognized (a spline tour before its first whole lap);
//! - `auto_young` and `cv_young`: the automatic stage and constant velocity scored at
//!   evaluation times *before* the warm-up, every `young_every_s` from the first (a track
//!   seen for 3 to 27 s by default): what a plan reads in a mission's first half-minute,
//!   before the obstacle has shown enough flight for replay or a lap; the other rows never
//!   see those times;
//! - `auto_contained` and `auto_leaving`: the automatic stage's scores after the warm-up
//!   again, for the turning behaviours only, split by whether the obstacle's true path from
//!   the evaluation to the horizon stays inside the simulator's containment circle
//!   ([`crate::scenario::containment`]; read every [`CONTAINMENT_STEP_S`]) or goes beyond
//!   it, where the simulator turns it back toward the mission at its largest turn rate (a
//!   rule of the simulator's, not of the obstacle's own past: what the predictor cannot
//!   learn from a track that has not met the edge yet);
//! - constant velocity: an isotropic Gaussian centred on the least-squares CV extrapolation
//!   (3 s window) with `sigma = 2 m + 0.1 * speed * horizon` (a stated, not fitted, spread).
//!
//! Scores: negative log-likelihood `-ln p(truth)` (density floored at 1e-12 per m^2, so a
//! miss costs at most 27.6), and coverage of the 95% highest-density region (the truth's
//! density at or above the 5th percentile of the samples' own densities; for CV, inside the
//! 95% circle `2.448 sigma`).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use predictor::{Observation, Predictor, PredictorConfig, Stage};

use crate::behaviour::{BehaviourKind, Trajectory};
use crate::geometry::P2;
use crate::scenario::{Family, ScenarioParams, containment, generate};
use crate::strategy::constant_velocity::fit_cv;
use crate::telemetry::{TelemetryParams, sample_streams};

/// Parameters. Defaults: 20 seeds per behaviour, horizons 1, 3, 5, 10, 20 s, 256 samples,
/// evaluation every 10 s after 30 s of telemetry (and every 3 s before that for the
/// `_young` rows), default telemetry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PredictionParams {
    /// Seeds per behaviour.
    pub seeds: u64,
    /// Horizons, seconds.
    pub horizons_s: Vec<f64>,
    /// Samples per prediction.
    pub samples: usize,
    /// Seconds between evaluations.
    pub eval_every_s: f64,
    /// Telemetry before the first evaluation, seconds.
    pub warmup_s: f64,
    /// Seconds between the evaluations of the `_young` rows, from this time until the
    /// warm-up; 0 leaves them out.
    pub young_every_s: f64,
    /// Telemetry.
    pub telemetry: TelemetryParams,
}

impl Default for PredictionParams {
    fn default() -> Self {
        Self {
            seeds: 20,
            horizons_s: vec![1.0, 3.0, 5.0, 10.0, 20.0],
            samples: 256,
            eval_every_s: 10.0,
            warmup_s: 30.0,
            young_every_s: 3.0,
            telemetry: TelemetryParams::default(),
        }
    }
}

/// One line: a behaviour, a method, a horizon.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PredictionRow {
    /// Behaviour.
    pub behaviour: BehaviourKind,
    /// `no_fly`, `random`, `advanced`, `memory`, `auto`, `cv`, `auto_no_lap`, `auto_young`,
    /// `cv_young`, `auto_contained` or `auto_leaving`.
    pub method: String,
    /// Horizon, seconds.
    pub horizon_s: f64,
    /// Predictions scored.
    pub n: usize,
    /// Mean negative log-likelihood (nats, per m^2 density).
    pub nll: f64,
    /// Fraction of truths inside the 95% region.
    pub coverage_95: f64,
}

const FLOOR: f64 = 1e-12;

/// Kernel density at `x` of `samples` with isotropic bandwidth `h`.
fn kde(samples: &[[f64; 2]], h: f64, x: [f64; 2]) -> f64 {
    let k = 1.0 / (2.0 * std::f64::consts::PI * h * h * samples.len() as f64);
    samples
        .iter()
        .map(|s| (-((s[0] - x[0]).powi(2) + (s[1] - x[1]).powi(2)) / (2.0 * h * h)).exp())
        .sum::<f64>()
        * k
}

/// The least kernel bandwidth, metres: only keeps the density finite where every sample is
/// the same point. It was 1 m until 2026-12-05, which scored the kernel rather than the
/// prediction wherever a cloud was a metre or two wide (a lapped tour, any obstacle one
/// second ahead): the region grew by the kernel and covered more than the cloud did (README,
/// "Prediction report").
pub const MIN_BANDWIDTH_M: f64 = 1e-3;

/// Silverman bandwidth for 2-D samples (pooled sigma), at least [`MIN_BANDWIDTH_M`].
fn bandwidth(samples: &[[f64; 2]]) -> f64 {
    let n = samples.len() as f64;
    let m = [
        samples.iter().map(|s| s[0]).sum::<f64>() / n,
        samples.iter().map(|s| s[1]).sum::<f64>() / n,
    ];
    let var = samples
        .iter()
        .map(|s| (s[0] - m[0]).powi(2) + (s[1] - m[1]).powi(2))
        .sum::<f64>()
        / (2.0 * n);
    (var.sqrt() * n.powf(-1.0 / 6.0)).max(MIN_BANDWIDTH_M)
}

/// `(nll, covered)` of `truth` under the kernel density of `samples`.
pub fn score_samples(samples: &[[f64; 2]], truth: [f64; 2]) -> (f64, bool) {
    let h = bandwidth(samples);
    let p = kde(samples, h, truth);
    let mut own: Vec<f64> = samples.iter().map(|s| kde(samples, h, *s)).collect();
    own.sort_by(f64::total_cmp);
    let thr = own[((0.05 * own.len() as f64).floor() as usize).min(own.len() - 1)];
    (-(p.max(FLOOR)).ln(), p >= thr)
}

/// `(nll, covered)` of `truth` under an isotropic Gaussian.
pub fn score_gaussian(mean: [f64; 2], sigma: f64, truth: [f64; 2]) -> (f64, bool) {
    let d2 = (truth[0] - mean[0]).powi(2) + (truth[1] - mean[1]).powi(2);
    let p = (-d2 / (2.0 * sigma * sigma)).exp() / (2.0 * std::f64::consts::PI * sigma * sigma);
    (-(p.max(FLOOR)).ln(), d2.sqrt() <= 2.448 * sigma)
}

fn family_of(b: BehaviourKind) -> Family {
    match b {
        BehaviourKind::Straight => Family::Straight,
        BehaviourKind::Random => Family::Random,
        BehaviourKind::Biased => Family::Biased,
        BehaviourKind::Patterned => Family::Patterned,
        BehaviourKind::Spline => Family::Spline,
    }
}

/// `auto_no_lap` is `auto` scored only while no lap of the obstacle's tour is recognized
/// (a spline tour before its first lap; every other behaviour always); `auto_young` and
/// `cv_young` are scored only at the evaluations before the warm-up, the others only after;
/// `auto_contained` and `auto_leaving` split `auto` of the turning behaviours by
/// [`leaves_containment`].
const METHODS: [&str; 11] = [
    "no_fly",
    "random",
    "advanced",
    "memory",
    "auto",
    "cv",
    "auto_no_lap",
    "auto_young",
    "cv_young",
    "auto_contained",
    "auto_leaving",
];

/// Step at which `auto_contained` / `auto_leaving` read the truth against the containment
/// circle, seconds (the turning behaviours decide once a second).
pub const CONTAINMENT_STEP_S: f64 = 0.5;

/// Whether `track` is beyond the circle (`center`, `radius_m`) at any step of
/// [`CONTAINMENT_STEP_S`] from `t0_s` to `t1_s` (both ends read).
pub fn leaves_containment(
    track: &Trajectory,
    center: P2,
    radius_m: f64,
    t0_s: f64,
    t1_s: f64,
) -> bool {
    let steps = ((t1_s - t0_s) / CONTAINMENT_STEP_S).ceil().max(0.0) as usize;
    (0..=steps).any(|k| {
        let p = track.at((t0_s + k as f64 * CONTAINMENT_STEP_S).min(t1_s));
        (p[0] - center[0]).hypot(p[1] - center[1]) > radius_m
    })
}

/// Runs the prediction report for `behaviours`.
pub fn prediction_report(
    behaviours: &[BehaviourKind],
    params: &PredictionParams,
) -> Vec<PredictionRow> {
    use rayon::prelude::*;
    let stages = [Stage::NoFly, Stage::Random, Stage::Advanced, Stage::Memory];
    let mut rows = Vec::new();
    for &b in behaviours {
        // per seed: sums [method][horizon] of (nll, covered, n)
        let per_seed: Vec<Vec<Vec<(f64, usize, usize)>>> = (0..params.seeds)
            .into_par_iter()
            .map(|seed| {
                let mut acc = vec![vec![(0.0, 0, 0); params.horizons_s.len()]; METHODS.len()];
                let s = generate(family_of(b), seed, &ScenarioParams::default());
                let (contain_center, contain_radius) = containment(&s.mission);
                let streams = sample_streams(&s, &params.telemetry);
                let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9E3D_1C7A);
                let max_h = params.horizons_s.iter().copied().fold(0.0, f64::max);
                let mut pred = Predictor::new(PredictorConfig::default());
                let mut fed = vec![0usize; streams.len()];
                let mut evals = Vec::new();
                if params.young_every_s > 0.0 {
                    let mut t = params.young_every_s;
                    while t < params.warmup_s && t + max_h <= s.duration_s {
                        evals.push((t, true));
                        t += params.young_every_s;
                    }
                }
                let mut t = params.warmup_s;
                while t + max_h <= s.duration_s {
                    evals.push((t, false));
                    t += params.eval_every_s;
                }
                for (t_e, young) in evals {
                    // Rows of `METHODS` the automatic stage and constant velocity score into.
                    let (auto_row, cv_row) = if young { (7, 8) } else { (4, 5) };
                    for (i, st) in streams.iter().enumerate() {
                        let n = st.partition_point(|o| o.t_s <= t_e);
                        for o in &st[fed[i]..n] {
                            let obs = Observation {
                                t_s: o.t_s,
                                p_m: [o.p_m[0], o.p_m[1]],
                                alt_m: o.p_m[2],
                                radius_m: o.radius_m,
                            };
                            pred.observe(&i.to_string(), obs);
                        }
                        fed[i] = n;
                    }
                    for (i, sp) in s.spheres.iter().enumerate() {
                        let id = i.to_string();
                        let track = &streams[i][..fed[i]];
                        let (Some(last), Some(cv)) = (track.last(), fit_cv(track, 3.0)) else {
                            continue;
                        };
                        let speed = cv.v_mps[0].hypot(cv.v_mps[1]);
                        for (hi, h) in params.horizons_s.iter().enumerate() {
                            let t = t_e + h;
                            let truth = sp.track.at(t);
                            let truth = [truth[0], truth[1]];
                            let dt = t - last.t_s;
                            let mut add = |row: usize, (nll, cov): (f64, bool)| {
                                acc[row][hi].0 += nll;
                                acc[row][hi].1 += usize::from(cov);
                                acc[row][hi].2 += 1;
                            };
                            // The forced stages and `auto_no_lap` are scored after the
                            // warm-up only.
                            for (mi, st) in stages.iter().enumerate().filter(|_| !young) {
                                if let Some(smp) = pred.sample_future_with_stage(
                                    &id,
                                    *st,
                                    dt,
                                    params.samples,
                                    &mut rng,
                                ) {
                                    add(mi, score_samples(&smp, truth));
                                }
                            }
                            if let Some(smp) = pred.sample_future(&id, dt, params.samples, &mut rng)
                            {
                                let score = score_samples(&smp, truth);
                                add(auto_row, score);
                                if !young && pred.model(&id).is_some_and(|m| m.lap.is_none()) {
                                    add(6, score);
                                }
                                if !young && b != BehaviourKind::Spline {
                                    let leaving = leaves_containment(
                                        &sp.track,
                                        contain_center,
                                        contain_radius,
                                        t_e,
                                        t,
                                    );
                                    add(if leaving { 10 } else { 9 }, score);
                                }
                            }
                            add(
                                cv_row,
                                score_gaussian(cv.at(t), 2.0 + 0.1 * speed * h, truth),
                            );
                        }
                    }
                }
                acc
            })
            .collect();
        for (mi, m) in METHODS.iter().enumerate() {
            for (hi, h) in params.horizons_s.iter().enumerate() {
                let (mut nll, mut cov, mut n) = (0.0, 0, 0);
                for a in &per_seed {
                    nll += a[mi][hi].0;
                    cov += a[mi][hi].1;
                    n += a[mi][hi].2;
                }
                rows.push(PredictionRow {
                    behaviour: b,
                    method: (*m).to_string(),
                    horizon_s: *h,
                    n,
                    nll: if n > 0 { nll / n as f64 } else { f64::NAN },
                    coverage_95: if n > 0 {
                        cov as f64 / n as f64
                    } else {
                        f64::NAN
                    },
                });
            }
        }
    }
    rows
}

/// The prediction report as a Markdown table: one line per behaviour and method, NLL and
/// coverage per horizon.
pub fn prediction_markdown(rows: &[PredictionRow]) -> String {
    use std::fmt::Write;
    let mut horizons: Vec<f64> = rows.iter().map(|r| r.horizon_s).collect();
    horizons.sort_by(f64::total_cmp);
    horizons.dedup();
    let mut s = String::from("| behaviour | method |");
    for h in &horizons {
        let _ = write!(s, " NLL +{h:.0} s | cov95 +{h:.0} s |");
    }
    s.push_str("\n|---|---|");
    for _ in &horizons {
        s.push_str("---:|---:|");
    }
    s.push('\n');
    for b in BehaviourKind::ALL {
        for m in METHODS {
            let line: Vec<&PredictionRow> = rows
                .iter()
                .filter(|r| r.behaviour == b && r.method == m)
                .collect();
            // (a method that scores no window of this behaviour, as the containment rows
            // of a spline tour, has no line)
            if line.iter().all(|r| r.n == 0) {
                continue;
            }
            let _ = write!(s, "| {} | {} |", b.name(), m);
            for h in &horizons {
                match line.iter().find(|r| r.horizon_s == *h) {
                    Some(r) => {
                        let _ = write!(s, " {:.2} | {:.0}% |", r.nll, 100.0 * r.coverage_95);
                    }
                    None => s.push_str(" | |"),
                }
            }
            s.push('\n');
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gaussian_scores_its_centre_and_misses_far_points() {
        // sigma = 1: density at the centre 1/(2 pi) -> NLL = ln(2 pi) = 1.8379
        let (nll, cov) = score_gaussian([0.0, 0.0], 1.0, [0.0, 0.0]);
        assert!((nll - (2.0 * std::f64::consts::PI).ln()).abs() < 1e-12);
        assert!(cov);
        // 2.5 sigma away: outside the 95% circle (2.448 sigma)
        assert!(!score_gaussian([0.0, 0.0], 1.0, [2.5, 0.0]).1);
        // very far: floored at -ln(1e-12) = 27.63
        assert!((score_gaussian([0.0, 0.0], 1.0, [1e3, 0.0]).0 - 27.631).abs() < 1e-3);
    }

    #[test]
    fn the_young_rows_score_only_the_evaluations_before_the_warm_up() {
        let count = |rows: &[PredictionRow], m: &str| -> usize {
            rows.iter()
                .filter(|r| r.method == m && r.horizon_s == 1.0)
                .map(|r| r.n)
                .sum()
        };
        let base = PredictionParams {
            seeds: 1,
            horizons_s: vec![1.0],
            samples: 32,
            ..Default::default()
        };
        let without = prediction_report(
            &[BehaviourKind::Straight],
            &PredictionParams {
                young_every_s: 0.0,
                ..base.clone()
            },
        );
        let with = prediction_report(&[BehaviourKind::Straight], &base);
        assert_eq!(count(&without, "auto_young"), 0);
        assert_eq!(count(&without, "cv_young"), 0);
        // The rows after the warm-up see the same evaluations either way.
        for m in ["auto", "cv", "random", "no_fly"] {
            assert!(count(&with, m) > 0, "{m}");
            assert_eq!(count(&with, m), count(&without, m), "{m}");
        }
        // 3, 6, ..., 27 s: nine evaluations per sphere seen by then, each scored once by
        // each young method.
        let young = count(&with, "cv_young");
        assert!(young > 0);
        assert_eq!(count(&with, "auto_young"), young);
        let s = generate(Family::Straight, 0, &ScenarioParams::default());
        assert!(
            young <= 9 * s.spheres.len(),
            "{young} for {} spheres",
            s.spheres.len()
        );
        assert!(
            young >= 8 * s.spheres.len(),
            "{young} for {} spheres",
            s.spheres.len()
        );
    }

    #[test]
    fn a_track_leaves_the_circle_only_where_a_step_is_beyond_it() {
        // east at 10 m/s from the origin, sampled every 0.1 s: at x = 100 m from 10 s on
        let track = Trajectory {
            dt_s: 0.1,
            samples_m: (0..=300).map(|i| [f64::from(i), 0.0, 50.0]).collect(),
        };
        let c = [0.0, 0.0];
        assert!(!leaves_containment(&track, c, 100.5, 0.0, 10.0));
        assert!(leaves_containment(&track, c, 99.5, 0.0, 10.0));
        // the window's far end is read even off the step grid
        assert!(leaves_containment(&track, c, 99.5, 9.8, 9.96));
        assert!(!leaves_containment(&track, c, 99.5, 0.0, 9.9));
        // a window starting beyond the circle leaves it
        assert!(leaves_containment(&track, c, 50.0, 6.0, 7.0));
    }

    /// `auto_contained` and `auto_leaving` split `auto` of the turning behaviours: their
    /// counts add up to `auto`'s and so do their summed NLL and coverage; a spline tour
    /// scores neither. Straight flyers are turned back by the containment often enough that
    /// both rows have windows at +20 s.
    #[test]
    fn the_containment_rows_split_the_automatic_stage_of_turning_behaviours() {
        let params = PredictionParams {
            seeds: 2,
            horizons_s: vec![1.0, 20.0],
            samples: 32,
            young_every_s: 0.0,
            ..Default::default()
        };
        let rows = prediction_report(&[BehaviourKind::Straight, BehaviourKind::Spline], &params);
        let row = |b: BehaviourKind, m: &str, h: f64| {
            rows.iter()
                .find(|r| r.behaviour == b && r.method == m && r.horizon_s == h)
                .unwrap_or_else(|| panic!("{m} +{h}"))
                .clone()
        };
        for h in [1.0, 20.0] {
            let all = row(BehaviourKind::Straight, "auto", h);
            let inside = row(BehaviourKind::Straight, "auto_contained", h);
            let leaving = row(BehaviourKind::Straight, "auto_leaving", h);
            assert_eq!(inside.n + leaving.n, all.n, "+{h} s");
            let sum = |r: &PredictionRow, x: f64| if r.n > 0 { x * r.n as f64 } else { 0.0 };
            let nll = sum(&inside, inside.nll) + sum(&leaving, leaving.nll);
            assert!(
                (nll - all.nll * all.n as f64).abs() < 1e-6 * all.n as f64,
                "+{h} s"
            );
            let cov = sum(&inside, inside.coverage_95) + sum(&leaving, leaving.coverage_95);
            assert!(
                (cov - all.coverage_95 * all.n as f64).abs() < 1e-6,
                "+{h} s"
            );
            assert_eq!(row(BehaviourKind::Spline, "auto_contained", h).n, 0);
            assert_eq!(row(BehaviourKind::Spline, "auto_leaving", h).n, 0);
        }
        let md = prediction_markdown(&rows);
        assert!(md.contains("| straight | auto_leaving |"), "{md}");
        assert!(!md.contains("| spline | auto_leaving |"), "{md}");
        let far_leaving = row(BehaviourKind::Straight, "auto_leaving", 20.0).n;
        let far_inside = row(BehaviourKind::Straight, "auto_contained", 20.0).n;
        assert!(
            far_leaving > 0 && far_inside > 0,
            "{far_leaving} / {far_inside}"
        );
        // a wider window meets the edge at least as often as a narrower one
        assert!(far_leaving >= row(BehaviourKind::Straight, "auto_leaving", 1.0).n);
    }

    #[test]
    fn samples_cover_a_truth_among_them_and_not_one_far_away() {
        // a 10 x 10 grid of samples 1 m apart around the origin
        let s: Vec<[f64; 2]> = (0..100)
            .map(|i| [f64::from(i % 10) - 4.5, f64::from(i / 10) - 4.5])
            .collect();
        let (near_nll, near) = score_samples(&s, [0.0, 0.0]);
        let (far_nll, far) = score_samples(&s, [50.0, 0.0]);
        assert!(near && !far);
        assert!(near_nll < far_nll);
    }

    /// The region is the cloud's own however sharp it is: a cloud of sigma 0.2 m per axis
    /// has its 95% region within 0.49 m (2.45 sigma) of its centre, so a truth 0.8 m off is
    /// outside and one 0.3 m off inside (a 1 m kernel floor put both inside).
    #[test]
    fn a_sharp_clouds_region_is_its_own_not_the_kernels() {
        use rand_distr::{Distribution, Normal};
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let d = Normal::new(0.0, 0.2).unwrap();
        let s: Vec<[f64; 2]> = (0..512)
            .map(|_| [d.sample(&mut rng), d.sample(&mut rng)])
            .collect();
        let (_, inside) = score_samples(&s, [0.3, 0.0]);
        let (_, outside) = score_samples(&s, [0.8, 0.0]);
        assert!(inside && !outside, "inside {inside}, outside {outside}");
        // Coincident samples keep a finite density at their point.
        let (nll, covered) = score_samples(&[[5.0, 5.0]; 8], [5.0, 5.0]);
        assert!(nll.is_finite() && covered);
    }
}
