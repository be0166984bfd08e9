//! Invariants of the risk map (proptest) and calibration of the stage models (seeded
//! statistical tests with stated tolerances).

mod common;

use common::{Behaviour, Generator};
use predictor::{Predictor, PredictorConfig, ReplayConfig, RiskField, RiskMapConfig, Stage};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn behaviour(i: u8, w: f64) -> Behaviour {
    match i % 5 {
        0 => Behaviour::Straight,
        1 => Behaviour::Uniform { w },
        2 => Behaviour::Biased { w },
        3 => Behaviour::Zigzag { w },
        _ => Behaviour::Stationary,
    }
}

fn fed(
    b: Behaviour,
    speed: f64,
    radius: f64,
    seed: u64,
    secs: f64,
    cfg: PredictorConfig,
) -> (Predictor, Generator) {
    let mut p = Predictor::new(cfg);
    let mut g = Generator::new(b, speed, seed);
    g.radius_m = radius;
    for o in g.track(secs) {
        p.observe("0", o);
    }
    (p, g)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Each slice of an obstacle holds its stencils' area of probability (every particle
    /// carries 1/N and splats the stencil of its sub-cell position; a cell sums at most N/N
    /// = 1): between the smallest and the largest stencil, up to f32 rounding and the 1e-6
    /// clamp (relative 1e-3). The stencil approximates the disc
    /// pi (r + buffer)^2 to within the splat error of a 5 m grid (25% for the smallest
    /// radius, less for larger ones).
    #[test]
    fn probability_mass_per_slice_is_conserved(
        bi in 0u8..5, seed in 0u64..1000, speed in 3.0f64..20.0, radius in 9.0f64..40.0, sub in any::<bool>(),
        stage in prop_oneof![Just(None), Just(Some(Stage::Random)), Just(Some(Stage::Advanced)), Just(Some(Stage::Memory))],
    ) {
        let cfg = PredictorConfig::default().forced_stage(stage);
        let (p, _) = fed(behaviour(bi, 0.25), speed, radius, seed, 40.0, cfg);
        // The grid is centred on the obstacle and wider than it can fly in the horizon.
        let c = p.obstacle("0").unwrap().estimates.position_m;
        let mc = RiskMapConfig::default().bounds([c[0] - 700.0, c[1] - 700.0], [c[0] + 700.0, c[1] + 700.0]).time(1.0, 20.0).particles(64).subcell_splat(sub);
        let mut map = p.build_risk_map(&mc, &[], 40.0).unwrap();
        let area = map.stencil_area_m2(radius);
        let disc = std::f64::consts::PI * (radius + mc.buffer_m).powi(2);
        prop_assert!((area - disc).abs() / disc < 0.25, "stencil {area} vs disc {disc}");
        for k in 0..map.slices() {
            // Slices after 15 s use 10 m cells (the default resolution schedule): their
            // mass is that resolution's stencil area.
            // A particle splats the stencil of its sub-cell position (the cell centre's by
            // default), so the mass lies between the smallest and the largest of them.
            let [lo, hi] = map.slice_stencil_areas_m2(radius, k);
            let m = map.obstacle_mass_m2("0", k).unwrap();
            prop_assert!(m >= lo * (1.0 - 1e-3) && m <= hi * (1.0 + 1e-3), "slice {k}: {m} vs {lo}..{hi}");
        }
    }

    /// Risk is a probability everywhere, in and out of the grid and the horizon; the
    /// segment bound is at least the risk at the segment's sampled points (with the fine
    /// slices in the grid or read from the obstacles' runs).
    #[test]
    fn risk_is_a_probability_and_the_segment_bound_is_conservative(
        seeds in proptest::collection::vec(0u64..1000, 1..4),
        bis in proptest::collection::vec(0u8..5, 3),
        pts in proptest::collection::vec((-500.0f64..500.0, -500.0f64..500.0, 35.0f64..75.0), 20),
        sparse in any::<bool>(),
    ) {
        let mut p = Predictor::new(PredictorConfig::default());
        for (i, s) in seeds.iter().enumerate() {
            let mut g = Generator::new(behaviour(bis[i % 3], 0.25), 12.0, *s);
            for mut o in g.track(40.0) {
                o.p_m = [o.p_m[0] * 0.3 + 100.0 * i as f64, o.p_m[1] * 0.3];
                p.observe(&i.to_string(), o);
            }
        }
        p.observe("new", predictor::Observation { t_s: 40.0, p_m: [-200.0, 200.0], alt_m: 0.0, radius_m: 20.0 });
        // With `sparse_fine` a read between the first 15 s's slices follows each cloud by
        // its mean's move, off the slices' own boxes: the bound must still hold it.
        let mc = RiskMapConfig::default().bounds([-400.0, -400.0], [400.0, 400.0]).time(1.0, 20.0).particles(64).sparse_fine(sparse);
        let map = p.risk_map(&mc, &[], 40.0);
        for w in pts.windows(2) {
            let (a, b) = ([w[0].0, w[0].1], [w[1].0, w[1].1]);
            let r = map.risk(a, w[0].2);
            prop_assert!((0.0..=1.0).contains(&r));
            let (t0, t1) = (w[0].2.min(w[1].2), w[0].2.max(w[1].2));
            let bound = map.segment_risk_bound(a, b, t0, t1);
            for i in 0..=32 {
                let f = f64::from(i) / 32.0;
                let q = [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f];
                for t in [t0, t1, 0.5 * (t0 + t1)] {
                    prop_assert!(map.risk(q, t) <= bound + 1e-9, "risk {} > bound {bound}", map.risk(q, t));
                }
            }
        }
    }
}

/// Fraction of trials in which the true position `horizon_s` after the last observation
/// falls in the model's 95% region: the disc around the mean of 1000 sampled futures whose
/// radius is the 95th percentile of their distances to that mean.
fn coverage(stage: Stage, b: Behaviour, track_s: f64, trials: u64) -> f64 {
    let horizon_s = 10.0;
    let mut hits = 0;
    for seed in 0..trials {
        let cfg = PredictorConfig::default().forced_stage(Some(stage));
        let (p, mut g) = fed(b, 15.0, 9.144, 1000 + seed, track_s, cfg);
        let truth = g.advance(horizon_s);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let s = p.sample_future("0", horizon_s, 1000, &mut rng).unwrap();
        let (mean, r95) = disc95(&s);
        if (truth[0] - mean[0]).hypot(truth[1] - mean[1]) <= r95 {
            hits += 1;
        }
    }
    let c = hits as f64 / trials as f64;
    eprintln!("coverage {stage:?}: {c}");
    c
}

/// Tolerance: coverage in [0.88, 0.99] over 80 seeded trials (a binomial standard error of
/// 0.024 at 95%, plus the models' own estimation error: the capability is a 5% radius
/// quantile, the histograms are smoothed).
fn assert_covers_about_95_percent(stage: Stage, b: Behaviour, track_s: f64) {
    let c = coverage(stage, b, track_s, 80);
    assert!((0.88..=0.99).contains(&c), "{stage:?} coverage {c}");
}

/// A 15 degree-per-second turn rate, in radians per second.
fn w15() -> f64 {
    15f64.to_radians()
}

#[test]
fn the_random_stage_95_percent_region_covers_uniform_turners() {
    assert_covers_about_95_percent(Stage::Random, Behaviour::Uniform { w: w15() }, 60.0);
}

#[test]
fn the_advanced_stage_95_percent_region_covers_biased_turners() {
    assert_covers_about_95_percent(Stage::Advanced, Behaviour::Biased { w: w15() }, 100.0);
}

#[test]
fn the_memory_stage_95_percent_region_covers_zigzag_turners() {
    assert_covers_about_95_percent(Stage::Memory, Behaviour::Zigzag { w: w15() }, 120.0);
}

/// The 95% disc of `s` (as in [`coverage`]): its centre and radius.
fn disc95(s: &[[f64; 2]]) -> ([f64; 2], f64) {
    let n = s.len() as f64;
    let mean = [
        s.iter().map(|q| q[0]).sum::<f64>() / n,
        s.iter().map(|q| q[1]).sum::<f64>() / n,
    ];
    let mut d: Vec<f64> = s
        .iter()
        .map(|q| (q[0] - mean[0]).hypot(q[1] - mean[1]))
        .collect();
    d.sort_by(f64::total_cmp);
    (mean, d[(0.95 * n) as usize])
}

/// Whether the 95% disc of 1000 of `p`'s samples of obstacle "0" `h` seconds ahead covers
/// `truth`, and the disc's radius.
fn disc_covers(p: &Predictor, h: f64, truth: [f64; 2], rng: &mut ChaCha8Rng) -> (bool, f64) {
    let (mean, r95) = disc95(&p.sample_future("0", h, 1000, rng).unwrap());
    ((truth[0] - mean[0]).hypot(truth[1] - mean[1]) <= r95, r95)
}

/// The radius of the 95% disc of 1000 of `p`'s samples of obstacle "0" `h` seconds ahead.
fn radius95(p: &Predictor, h: f64, rng: &mut ChaCha8Rng) -> f64 {
    disc95(&p.sample_future("0", h, 1000, rng).unwrap()).1
}

/// Over seeded trials fed the telemetry a ground station gets (2 Hz, 1 m Gaussian noise per
/// axis, `track_s` of it): the fraction in which the true position `horizon_s` after the last
/// observation falls in the automatic prediction's 95% disc, and the mean radii of that disc
/// and of the random stage's. Also checks that the prediction replays the obstacle's own
/// past ([`predictor::replay`]).
fn auto_noisy(b: Behaviour, track_s: f64, horizon_s: f64, trials: u64) -> (f64, f64, f64) {
    use rand_distr::{Distribution, Normal};
    let noise = Normal::new(0.0, 1.0).unwrap();
    let (mut hits, mut r_auto, mut r_random) = (0, 0.0, 0.0);
    for seed in 0..trials {
        let mut p = Predictor::new(PredictorConfig::default());
        let mut g = Generator::new(b, 15.0, 5000 + seed);
        let mut nrng = ChaCha8Rng::seed_from_u64(77 + seed);
        for (k, mut o) in g.track(track_s).into_iter().enumerate() {
            if k % 5 == 0 {
                o.p_m[0] += noise.sample(&mut nrng);
                o.p_m[1] += noise.sample(&mut nrng);
                p.observe("0", o);
            }
        }
        assert!(
            p.model("0").unwrap().replay.is_some(),
            "seed {seed}: no replay"
        );
        let truth = g.advance(horizon_s);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (covered, r95) = disc_covers(&p, horizon_s, truth, &mut rng);
        hits += u32::from(covered);
        r_auto += r95 / trials as f64;
        let s = p
            .sample_future_with_stage("0", Stage::Random, horizon_s, 1000, &mut rng)
            .unwrap();
        r_random += disc95(&s).1 / trials as f64;
    }
    let c = hits as f64 / trials as f64;
    eprintln!(
        "auto {b:?} +{horizon_s} s: coverage {c}, r95 {r_auto:.1} m (random stage {r_random:.1} m)"
    );
    (c, r_auto, r_random)
}

/// Replay's spread comes from the obstacle's own past, estimated as noisily as its present
/// state: after four minutes of watching, its 95% disc must cover at least 88% of truths
/// (the band of [`assert_covers_about_95_percent`]; above 95% is allowed, as the replayed
/// displacements carry the observation noise the noise-free truth lacks) at short and long
/// horizons alike, and be tighter than the random stage's.
fn assert_auto_covers_and_is_sharper(b: Behaviour) {
    for h in [2.0, 10.0, 20.0] {
        let (c, r_auto, r_random) = auto_noisy(b, 240.0, h, 80);
        assert!(c >= 0.88, "{b:?} +{h} s coverage {c}");
        assert!(
            r_auto < r_random,
            "{b:?} +{h} s: {r_auto} m vs {r_random} m"
        );
    }
}

#[test]
fn replayed_predictions_cover_a_constant_turn_mover_from_noisy_telemetry() {
    // 0.02 rad/s at 15 m/s: a 750 m circle, no lap closed in the 240 s watched.
    assert_auto_covers_and_is_sharper(Behaviour::Circling { w: 0.02 });
}

#[test]
fn replayed_predictions_cover_uniform_turners_from_noisy_telemetry() {
    assert_auto_covers_and_is_sharper(Behaviour::Uniform { w: w15() });
}

#[test]
fn replayed_predictions_cover_zigzag_turners_from_noisy_telemetry() {
    assert_auto_covers_and_is_sharper(Behaviour::Zigzag { w: w15() });
}

/// The judges' two-waypoint tour (a line, slowing to a stop at each end): 300 m either
/// side of its centre every 120 s, 15.7 m/s at the centre, turning back at t = 40 s.
fn out_and_back(t: f64) -> [f64; 2] {
    let x = 300.0 * (2.0 * std::f64::consts::PI * (t - 10.0) / 120.0).sin();
    [1000.0 + 0.6 * x, 2000.0 - 0.8 * x]
}

/// [`out_and_back`] seen at 2 Hz with 1 m noise per axis, `n + 1` observations from `t0`.
fn out_and_back_seen(t0: f64, n: u32, seed: u64) -> Vec<predictor::Observation> {
    use rand_distr::{Distribution, Normal};
    let noise = Normal::new(0.0, 1.0).unwrap();
    let mut nrng = ChaCha8Rng::seed_from_u64(seed);
    (0..=n)
        .map(|k| {
            let t = t0 + f64::from(k) * 0.5;
            let [x, y] = out_and_back(t);
            predictor::Observation {
                t_s: t,
                p_m: [x + noise.sample(&mut nrng), y + noise.sample(&mut nrng)],
                alt_m: 100.0,
                radius_m: 10.0,
            }
        })
        .collect()
}

/// An out-and-back obstacle (the judges' two-waypoint tour: a line, slowing to a stop at each
/// end), 300 m either side of its centre every 120 s (15.7 m/s at the centre), turning back
/// at t = 40 s, seen at 2 Hz with 1 m noise per axis for 65 s (25 s after the turn-back).
/// From the turn-back on it retraces its own track backward, so the prediction must follow
/// that track ([`predictor::LapKind::Mirror`]): over seeded trials the 95% disc covers the
/// truth at least 88% of the time at +5 and +12 s and is at most half the radius of the
/// prediction made without lap search (manoeuvre replay alone, which cannot know the
/// obstacle will come back the way it went).
#[test]
fn an_out_and_back_obstacle_is_predicted_backward_along_its_own_track_after_turning_back() {
    let truth = out_and_back;
    let trials = 40u32;
    for h in [5.0, 12.0] {
        let (mut hits, mut r_with, mut r_without, mut r_smooth) = (0, 0.0, 0.0, 0.0);
        for seed in 0..trials {
            let mut with = Predictor::new(PredictorConfig::default());
            let mut without = Predictor::new(PredictorConfig {
                periodic: None,
                replay: Some(ReplayConfig {
                    smooth_window_s: 0.0,
                    ..ReplayConfig::default()
                }),
                ..PredictorConfig::default()
            });
            let mut smooth = Predictor::new(PredictorConfig {
                periodic: None,
                ..PredictorConfig::default()
            });
            for o in out_and_back_seen(0.0, 130, 900 + u64::from(seed)) {
                with.observe("0", o);
                without.observe("0", o);
                smooth.observe("0", o);
            }
            let lap = with.model("0").unwrap().lap;
            assert_eq!(
                lap.map(|l| l.kind),
                Some(predictor::LapKind::Mirror),
                "seed {seed}: {lap:?}"
            );
            let mut rng = ChaCha8Rng::seed_from_u64(u64::from(seed));
            let (covered, r95) = disc_covers(&with, h, truth(65.0 + h), &mut rng);
            hits += u32::from(covered);
            r_with += r95 / f64::from(trials);
            r_without += radius95(&without, h, &mut rng) / f64::from(trials);
            r_smooth += radius95(&smooth, h, &mut rng) / f64::from(trials);
        }
        let c = f64::from(hits) / f64::from(trials);
        eprintln!(
            "out-and-back +{h} s: coverage {c}, r95 {r_with:.1} m (without lap search {r_without:.1} m, \
             with its smooth extrapolation {r_smooth:.1} m)"
        );
        assert!(c >= 0.88, "+{h} s coverage {c}");
        assert!(
            r_with < 0.5 * r_without,
            "+{h} s: {r_with} m vs {r_without} m"
        );
        assert!(r_with < r_smooth, "+{h} s: {r_with} m vs {r_smooth} m");
    }
}

/// The same out-and-back 9 s after its turn-back (seen from t = 20 s to 49 s): the whole
/// 10 s signature has not yet flown past the tip, so only the newest 4 s
/// ([`predictor::PeriodicConfig::mirror_window_s`]) can mirror it (issue 10, Webster Field
/// with mixed spheres, seed 464: a sphere 3-6 s past its turn-back predicted round the turn,
/// over the escape that would have cleared it). Over seeded trials the track is mirrored
/// with a period of twice the 9 s, and its 95% disc covers the truth at least 88% of the
/// time at +3, +6 and +10 s, with a smaller radius than the prediction made with the whole
/// window only (`mirror_window_s` 10 s: no lap yet), and less than half of it from +6 s on
/// (measured: 10.3 / 13.9 / 18.8 m against 16.1 / 41.0 / 79.7 m).
#[test]
fn an_out_and_back_is_predicted_backward_from_a_few_seconds_after_its_turn_back() {
    let truth = out_and_back;
    let trials = 40u32;
    let whole_window = PredictorConfig {
        periodic: Some(predictor::PeriodicConfig {
            mirror_window_s: 10.0,
            ..predictor::PeriodicConfig::default()
        }),
        ..PredictorConfig::default()
    };
    for h in [3.0, 6.0, 10.0] {
        let (mut hits, mut r_with, mut r_without) = (0, 0.0, 0.0);
        for seed in 0..trials {
            let mut with = Predictor::new(PredictorConfig::default());
            let mut without = Predictor::new(whole_window.clone());
            for o in out_and_back_seen(20.0, 58, 700 + u64::from(seed)) {
                with.observe("0", o);
                without.observe("0", o);
            }
            let lap = with.model("0").unwrap().lap;
            assert!(
                lap.is_some_and(
                    |l| l.kind == predictor::LapKind::Mirror && (l.period_s - 18.0).abs() < 1.0
                ),
                "seed {seed}: {lap:?}"
            );
            assert_eq!(without.model("0").unwrap().lap, None, "seed {seed}");
            let mut rng = ChaCha8Rng::seed_from_u64(u64::from(seed));
            let (covered, r95) = disc_covers(&with, h, truth(49.0 + h), &mut rng);
            hits += u32::from(covered);
            r_with += r95 / f64::from(trials);
            r_without += radius95(&without, h, &mut rng) / f64::from(trials);
        }
        let c = f64::from(hits) / f64::from(trials);
        eprintln!(
            "9 s after the turn-back, +{h} s: coverage {c}, r95 {r_with:.1} m (whole window only {r_without:.1} m)"
        );
        assert!(c >= 0.88, "+{h} s coverage {c}");
        // Near at hand both are tight (the sphere is still slow); further on the whole
        // window's prediction cannot know the sphere comes back the way it went.
        let ratio = if h < 5.0 { 1.0 } else { 0.5 };
        assert!(
            r_with < ratio * r_without,
            "+{h} s: {r_with} m vs {r_without} m"
        );
    }
}

/// A young track leaving a turn-back (the judges' two-waypoint tour of the test above,
/// seen from its turn-back at t = 40 s for 8 s at 2 Hz with 1 m noise per axis: slow and
/// speeding up, 6.5 m/s and 0.75 m/s^2 at the end). Replay needs 20 s of history, so the
/// stage model alone would fly on at the present speed and fall behind; the young track's
/// quadratic ([`predictor::young`]) carries the change of speed. Over seeded trials its 95%
/// disc covers the truth in at least 88% of them at +3, +5 and +10 s, where the prediction
/// without it (`young_horizon_s` 0) covers at most 70% at +10 s.
#[test]
fn a_young_track_speeding_up_out_of_a_turn_back_is_covered() {
    let truth = out_and_back;
    let trials = 60u32;
    for h in [3.0, 5.0, 10.0] {
        let (mut hits, mut hits_without, mut r_with) = (0, 0, 0.0);
        for seed in 0..trials {
            let mut with = Predictor::new(PredictorConfig::default());
            let mut without = Predictor::new(PredictorConfig {
                replay: Some(ReplayConfig {
                    young_horizon_s: 0.0,
                    ..ReplayConfig::default()
                }),
                ..PredictorConfig::default()
            });
            for o in out_and_back_seen(40.0, 16, 300 + u64::from(seed)) {
                with.observe("0", o);
                without.observe("0", o);
            }
            let m = with.model("0").unwrap();
            assert!(
                m.young.is_some() && m.replay.is_none(),
                "seed {seed}: {m:?}"
            );
            assert!(without.model("0").unwrap().young.is_none());
            let t = truth(48.0 + h);
            let mut rng = ChaCha8Rng::seed_from_u64(u64::from(seed));
            let (covered, r95) = disc_covers(&with, h, t, &mut rng);
            hits += u32::from(covered);
            r_with += r95 / f64::from(trials);
            hits_without += u32::from(disc_covers(&without, h, t, &mut rng).0);
        }
        let c = f64::from(hits) / f64::from(trials);
        let c_without = f64::from(hits_without) / f64::from(trials);
        eprintln!(
            "young, speeding up +{h} s: coverage {c} (without {c_without}), r95 {r_with:.1} m"
        );
        assert!(c >= 0.88, "+{h} s coverage {c}");
        if h >= 10.0 {
            assert!(c_without <= 0.7, "+{h} s coverage without {c_without}");
        }
    }
}

/// Coverage of the 95% disc `h` seconds ahead of a young track (`watch_s` of exact
/// 5 Hz positions, as the judges' server sends) of behaviour `b` at 15 m/s over `trials`
/// seeded trials, with the young track's turn bias (`young_bias_se` 2) and without (the
/// default).
fn young_coverage(b: Behaviour, watch_s: f64, h: f64, trials: u64) -> (f64, f64) {
    let (mut with, mut without) = (0u32, 0u32);
    for seed in 0..trials {
        let mut g = Generator::new(b, 15.0, 9100 + seed);
        let mut on = Predictor::new(PredictorConfig {
            replay: Some(ReplayConfig {
                young_bias_se: 2.0,
                ..ReplayConfig::default()
            }),
            ..PredictorConfig::default()
        });
        let mut off = Predictor::new(PredictorConfig::default());
        for (k, o) in g.track(watch_s).into_iter().enumerate() {
            if k % 2 == 0 {
                on.observe("0", o);
                off.observe("0", o);
            }
        }
        assert!(on.model("0").unwrap().young.is_some(), "seed {seed}");
        let truth = g.advance(h);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        with += u32::from(disc_covers(&on, h, truth, &mut rng).0);
        without += u32::from(disc_covers(&off, h, truth, &mut rng).0);
    }
    let n = trials as f64;
    (f64::from(with) / n, f64::from(without) / n)
}

/// A young track that leans one way (a biased turner, 0.1 rad/s on average with turns
/// redrawn every second within 0.08 of that), watched for 12 s at 5 Hz. Its quadratic
/// carries it for 10 s; after that the stage model's turns, drawn about zero, leave it
/// behind its own bend, and the young track's shown bias
/// ([`predictor::young::turn_bias_radps`], `young_bias_se` 2; off by default) carries it
/// round. Over 60 seeded trials the 95% disc covers the truth at +20 s in at least 80% of
/// them, against at most 65% without the bias (measured: 85% and 55%); at +10 s the two
/// are within 5 points (88% and 90%). A uniform turner (its mean turn within its noise)
/// keeps its coverage within 5 points at both horizons.
#[test]
fn a_young_track_leaning_one_way_is_predicted_round_its_bend() {
    let trials = 60;
    let lean = Behaviour::Leaning {
        mean: 0.1,
        spread: 0.08,
    };
    for h in [10.0, 20.0] {
        let (c, c_without) = young_coverage(lean, 12.0, h, trials);
        let (u, u_without) = young_coverage(Behaviour::Uniform { w: 0.3 }, 12.0, h, trials);
        eprintln!(
            "young +{h} s: leaning {c} (without the bias {c_without}), uniform {u} ({u_without})"
        );
        if h >= 20.0 {
            assert!(c >= 0.8, "leaning +{h} s coverage {c}");
            assert!(
                c_without <= 0.65,
                "leaning +{h} s without the bias {c_without}"
            );
        } else {
            assert!(
                (c - c_without).abs() <= 0.05,
                "leaning +{h} s {c} against {c_without}"
            );
        }
        assert!(
            u >= u_without - 0.05,
            "uniform +{h} s coverage {u} against {u_without}"
        );
    }
}

/// A closed tour flown again and again (a periodic, non-circular curve, 90 s a lap, 1-24
/// m/s), seen at 2 Hz with 1 m noise per axis for 150 s, so one lap is recognized
/// ([`predictor::LapKind::Repeat`]) and predicts the next from the observed one. The
/// prediction is one noisy observed pass, so it is about as good as one observation: over
/// seeded trials (in each of which the lap is recognized) its 95% disc covers the truth in at
/// least 88% of them at +1, +5 and +20 s, and its radius is at most twice the 95th
/// percentile of the prediction's actual error (the lap spread before, the match's RMS
/// plus 1 m growing by 5 cm/s, drew 8.9-10.9 m discs round errors of 2.6 m: 3.4-4 times).
#[test]
fn a_repeated_lap_is_predicted_about_as_tightly_as_it_was_observed() {
    use rand_distr::{Distribution, Normal};
    let w = 2.0 * std::f64::consts::PI / 90.0;
    let truth = |t: f64| {
        let a = w * t;
        [
            500.0 + 200.0 * a.cos() + 60.0 * (2.0 * a).sin(),
            800.0 + 140.0 * a.sin() - 40.0 * (3.0 * a).cos(),
        ]
    };
    let noise = Normal::new(0.0, 1.0).unwrap();
    let trials = 80u32;
    let horizons = [1.0, 5.0, 20.0];
    // Per horizon: truths inside the disc, the discs' radii and the errors.
    let mut hits = [0u32; 3];
    let mut r95s = [0.0; 3];
    let mut errs: [Vec<f64>; 3] = Default::default();
    for seed in 0..trials {
        let mut p = Predictor::new(PredictorConfig::default());
        let mut nrng = ChaCha8Rng::seed_from_u64(3000 + u64::from(seed));
        // Each trial starts elsewhere on the tour.
        let t0 = f64::from(seed) * 1.37;
        for k in 0..=300 {
            let t = t0 + f64::from(k) * 0.5;
            let [x, y] = truth(t);
            p.observe(
                "0",
                predictor::Observation {
                    t_s: t,
                    p_m: [x + noise.sample(&mut nrng), y + noise.sample(&mut nrng)],
                    alt_m: 100.0,
                    radius_m: 10.0,
                },
            );
        }
        // The lap search refines the lag within about two seconds of the observation
        // nearest the newest position; where the tour is slow, noise can put that one
        // over a second off (2 trials in 80 here when the refinement reached one
        // second): every trial must find its lap.
        let lap = p.model("0").unwrap().lap;
        assert_eq!(
            lap.map(|l| l.kind),
            Some(predictor::LapKind::Repeat),
            "seed {seed}: {lap:?}"
        );
        for (k, h) in horizons.into_iter().enumerate() {
            let mut rng = ChaCha8Rng::seed_from_u64(u64::from(seed));
            let (mean, r95) = disc95(&p.sample_future("0", h, 1000, &mut rng).unwrap());
            let t = truth(t0 + 150.0 + h);
            let e = (t[0] - mean[0]).hypot(t[1] - mean[1]);
            hits[k] += u32::from(e <= r95);
            errs[k].push(e);
            r95s[k] += r95 / f64::from(trials);
        }
    }
    for (k, h) in horizons.into_iter().enumerate() {
        let c = f64::from(hits[k]) / f64::from(trials);
        let r95 = r95s[k];
        errs[k].sort_by(f64::total_cmp);
        let e95 = errs[k][(0.95 * errs[k].len() as f64) as usize];
        eprintln!("repeated lap +{h} s: coverage {c}, r95 {r95:.1} m, error p95 {e95:.1} m");
        assert!(c >= 0.88, "+{h} s coverage {c}");
        assert!(
            r95 <= 2.0 * e95,
            "+{h} s: the 95% disc's radius {r95:.1} m is over twice the error's 95th percentile {e95:.1} m"
        );
    }
}
