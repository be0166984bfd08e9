//! Turn capability at speed (issue 10): an obstacle that turned tightly only while slow
//! (the judges' spline tours stop and reverse at their ends) must not be predicted to spin
//! at that rate while it cruises. Checked against the obstacle's true future position.

use predictor::{Observation, Predictor, PredictorConfig, Stage};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// A shuttle along a line: `x(t) = A (1 - cos(2 pi t / P))`, at rest at `t = 0`, fastest
/// (`A 2 pi / P`) at `t = P / 4`, heading north-east.
const A_M: f64 = 150.0;
const P_S: f64 = 40.0;
const DIR: [f64; 2] = [
    std::f64::consts::FRAC_1_SQRT_2,
    std::f64::consts::FRAC_1_SQRT_2,
];

fn truth(t: f64) -> [f64; 2] {
    let s = A_M * (1.0 - (std::f64::consts::TAU * t / P_S).cos());
    [s * DIR[0], s * DIR[1]]
}

/// The shuttle observed at 5 Hz with 1 m of noise per axis from `t = 0` to `until_s`.
fn observed(until_s: f64, seed: u64) -> Predictor {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 1.0).unwrap();
    let mut p = Predictor::new(PredictorConfig::default());
    let n = (until_s * 5.0).round() as usize;
    for i in 0..=n {
        let t = i as f64 / 5.0;
        let q = truth(t);
        p.observe(
            "0",
            Observation {
                t_s: t,
                p_m: [q[0] + noise.sample(&mut rng), q[1] + noise.sample(&mut rng)],
                alt_m: 100.0,
                radius_m: 35.0,
            },
        );
    }
    p
}

/// Fraction of `n` sampled futures at `+dt_s` within `within_m` of the true position.
fn covered(p: &Predictor, t_s: f64, dt_s: f64, within_m: f64, seed: u64) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = 1000;
    let q = truth(t_s + dt_s);
    let pts = p.sample_future("0", dt_s, n, &mut rng).unwrap();
    pts.iter()
        .filter(|s| (s[0] - q[0]).hypot(s[1] - q[1]) <= within_m)
        .count() as f64
        / n as f64
}

#[test]
fn a_cruising_obstacle_that_turned_only_while_slow_is_not_predicted_to_spin() {
    let mut coverage = vec![];
    for seed in 0..8 {
        // 12 s in: 22 m/s and nearly straight; the only tight "turns" were at rest.
        let t = 12.0;
        let p = observed(t, seed);
        let s = p.obstacle("0").unwrap();
        assert_eq!(s.stage, Stage::Random, "seed {seed}");
        let e = s.estimates;
        // The capability at 22 m/s is bounded by the lateral acceleration shown, far below
        // what a 5 m radius at walking pace would give at this speed (150-220 deg/s).
        assert!(e.turn_rate_max_dps < 60.0, "seed {seed}: {e:?}");
        // Where the obstacle really is 3 s on: the predicted mass within the sphere's
        // radius (the risk map adds its buffer on top).
        coverage.push(covered(&p, t, 3.0, 35.0, seed));
    }
    let mean = coverage.iter().sum::<f64>() / coverage.len() as f64;
    let worst = coverage.iter().copied().fold(1.0, f64::min);
    // Measured: 0.80-0.99 (mean 0.89). Spinning at the capability shown at rest (40-200
    // deg/s), 0.16-0.74 of the mass was there (mean 0.37).
    assert!(mean >= 0.8 && worst >= 0.7, "{coverage:?}");
}

#[test]
fn the_capability_at_constant_speed_is_the_demonstrated_turn_rate() {
    // 15 m/s on a 100 m circle: 8.6 deg/s demonstrated; at constant speed the lateral
    // acceleration bound (v^2 / r over v) gives the same rate, so nothing is lost.
    let mut p = Predictor::new(PredictorConfig::default());
    for i in 0..=600 {
        let t = f64::from(i) * 0.2;
        let a = 0.15 * t;
        p.observe(
            "0",
            Observation {
                t_s: t,
                p_m: [100.0 * a.cos(), 100.0 * a.sin()],
                alt_m: 100.0,
                radius_m: 10.0,
            },
        );
    }
    let e = p.obstacle("0").unwrap().estimates;
    let demonstrated = 0.15f64.to_degrees();
    assert!(
        e.turn_rate_max_dps >= demonstrated * 0.98,
        "capability {} below the demonstrated {demonstrated}",
        e.turn_rate_max_dps
    );
}
