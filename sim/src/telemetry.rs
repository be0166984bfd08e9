//! Obstacle telemetry as the ground station would receive it: sampled at a chosen rate from
//! the ground truth, with optional Gaussian position noise and random dropouts.
//!
//! The whole stream is drawn up front from the scenario's seed, so every strategy run on a
//! scenario sees exactly the same telemetry.
//!
//! # Units
//! Seconds, ENU metres, metres MSL.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::scenario::Scenario;

/// Telemetry sampling. Defaults: 2 Hz, 1 m noise (1 sigma, each axis), 5% dropouts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TelemetryParams {
    /// Samples per second.
    pub rate_hz: f64,
    /// Standard deviation of the Gaussian noise on each coordinate, metres.
    pub noise_sigma_m: f64,
    /// Probability that a sample is lost.
    pub dropout_prob: f64,
    /// Telemetry received before the aircraft starts, seconds: the obstacles are watched
    /// for this long before `t = 0` (on a competition field the ground station polls the
    /// judges' server from before take-off). Default 0: the obstacles are first seen when
    /// the aircraft starts, the hardest case. Drawn from its own random stream, so the
    /// telemetry from `t = 0` on is the same whatever the lead-in.
    #[serde(default)]
    pub lead_in_s: f64,
}

impl Default for TelemetryParams {
    fn default() -> Self {
        Self {
            rate_hz: 2.0,
            noise_sigma_m: 1.0,
            dropout_prob: 0.05,
            lead_in_s: 0.0,
        }
    }
}

impl TelemetryParams {
    planner::setters! {
        /// Sets the rate.
        rate_hz(rate_hz: f64);
        /// Sets the noise.
        noise_sigma_m(noise_sigma_m: f64);
        /// Sets the dropout probability.
        dropout_prob(dropout_prob: f64);
        /// Sets the lead-in, seconds.
        lead_in_s(lead_in_s: f64);
    }
}

/// One received obstacle observation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ObstacleObservation {
    /// Time stamp, mission seconds.
    pub t_s: f64,
    /// Position, ENU metres and MSL.
    pub p_m: [f64; 3],
    /// Sphere radius, metres.
    pub radius_m: f64,
}

/// Telemetry streams, one per moving sphere, in time order.
pub fn sample_streams(
    scenario: &Scenario,
    params: &TelemetryParams,
) -> Vec<Vec<ObstacleObservation>> {
    let mut rng = ChaCha8Rng::seed_from_u64(scenario.seed ^ 0x7E1E_0001);
    let noise = Normal::new(0.0, params.noise_sigma_m.max(0.0)).unwrap();
    let dt = 1.0 / params.rate_hz;
    let n = (scenario.duration_s / dt).floor() as usize;
    let lead = (params.lead_in_s.max(0.0) / dt).floor() as usize;
    let mut lead_rng = ChaCha8Rng::seed_from_u64(scenario.seed ^ 0x7E1E_0002);
    // One sample at `t_s` of true position `p_m`: the dropout drawn first, then the noise
    // (the same draws whether or not it is lost).
    let observe = |t_s: f64, mut p_m: [f64; 3], radius_m: f64, rng: &mut ChaCha8Rng| {
        let lost = rng.random::<f64>() < params.dropout_prob;
        for c in &mut p_m {
            *c += noise.sample(rng);
        }
        (!lost).then_some(ObstacleObservation { t_s, p_m, radius_m })
    };
    scenario
        .spheres
        .iter()
        .enumerate()
        .map(|(index, s)| {
            let mut out = Vec::with_capacity(lead + n + 1);
            if lead > 0 {
                let past = scenario.lead_in(index, lead as f64 * dt);
                out.extend((1..=lead).rev().filter_map(|k| {
                    let ago = k as f64 * dt;
                    observe(-ago, past.at(ago), s.radius_m, &mut lead_rng)
                }));
            }
            out.extend((0..=n).filter_map(|i| {
                let t_s = i as f64 * dt;
                observe(t_s, s.track.at(t_s), s.radius_m, &mut rng)
            }));
            out
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::behaviour::Behaviour;
    use crate::scenario::{Family, ScenarioParams, generate};

    fn noiseless(lead_in_s: f64) -> TelemetryParams {
        TelemetryParams::default()
            .rate_hz(5.0)
            .noise_sigma_m(0.0)
            .dropout_prob(0.0)
            .lead_in_s(lead_in_s)
    }

    #[test]
    fn a_lead_in_adds_telemetry_before_take_off_and_leaves_the_flight_unchanged() {
        for family in [Family::Mixed, Family::Spline] {
            let s = generate(family, 11, &ScenarioParams::default());
            assert!(!s.spheres.is_empty());
            let params = TelemetryParams::default();
            let without = sample_streams(&s, &params);
            let with = sample_streams(&s, &params.lead_in_s(120.0));
            for (a, b) in without.iter().zip(&with) {
                let from_zero: Vec<_> = b.iter().filter(|o| o.t_s >= 0.0).copied().collect();
                assert_eq!(
                    a, &from_zero,
                    "{family:?}: telemetry from take-off on changed"
                );
                let before: Vec<_> = b.iter().filter(|o| o.t_s < 0.0).collect();
                // 2 Hz over 120 s, 5% dropouts
                assert!((200..=240).contains(&before.len()), "{}", before.len());
                assert!(before.first().unwrap().t_s >= -120.0 - 1e-9);
                assert!(b.windows(2).all(|w| w[0].t_s < w[1].t_s), "time order");
            }
        }
    }

    #[test]
    fn the_flight_before_take_off_joins_the_truth_at_the_sphere_s_speed() {
        let mut turning = 0;
        for family in [Family::Mixed, Family::Spline] {
            for seed in 0..6 {
                let s = generate(family, seed, &ScenarioParams::default());
                let streams = sample_streams(&s, &noiseless(60.0));
                for (sp, obs) in s.spheres.iter().zip(&streams) {
                    // noiseless and without dropouts: 5 Hz from -60 s to the end
                    let i0 = obs.iter().position(|o| o.t_s == 0.0).unwrap();
                    assert_eq!(i0, 300);
                    assert_eq!(obs[i0].p_m, sp.track.at(0.0));
                    if let Behaviour::Spline(tour) = &sp.behaviour {
                        // a tour's past is its own tour (periodic): one period back is
                        // where it starts
                        for o in &obs[..i0] {
                            let p = tour.position(o.t_s);
                            let d = (p[0] - o.p_m[0]).hypot(p[1] - o.p_m[1]);
                            assert!(d < 1e-6, "{family:?} seed {seed} t {}: {d} m", o.t_s);
                        }
                        let p = tour.position(-tour.period_s());
                        let q = sp.track.at(0.0);
                        assert!((p[0] - q[0]).hypot(p[1] - q[1]) < 1e-6);
                        continue;
                    }
                    // a turning sphere flies at its constant speed into its start
                    turning += 1;
                    for w in obs[..=i0].windows(2) {
                        let d = (w[1].p_m[0] - w[0].p_m[0]).hypot(w[1].p_m[1] - w[0].p_m[1]);
                        let v = d / (w[1].t_s - w[0].t_s);
                        assert!(
                            (v - sp.speed_mps).abs() <= 0.02 * sp.speed_mps,
                            "{family:?} seed {seed} t {}: {v} m/s for {} m/s",
                            w[0].t_s,
                            sp.speed_mps
                        );
                    }
                    // and arrives heading the way it then goes on (no kink at take-off)
                    let (a, b, c) = (obs[i0 - 1].p_m, obs[i0].p_m, obs[i0 + 1].p_m);
                    let h0 = (b[1] - a[1]).atan2(b[0] - a[0]);
                    let h1 = (c[1] - b[1]).atan2(c[0] - b[0]);
                    let mut dh = (h1 - h0).abs();
                    if dh > std::f64::consts::PI {
                        dh = std::f64::consts::TAU - dh;
                    }
                    assert!(
                        dh < 0.2,
                        "{family:?} seed {seed}: {dh} rad kink at take-off"
                    );
                }
            }
        }
        assert!(turning >= 10, "{turning} turning spheres");
    }

    #[test]
    fn a_biased_sphere_turns_to_its_side_before_take_off_too() {
        // Heading change read forward in time over the minute before take-off: the side a
        // biased sphere favours (without the mirror, flown backward, it would be the other).
        // Containment turns a sphere back toward the mission at full rate, so a few go the
        // other way on the whole; most must not.
        let (mut total, mut agree) = (0, 0);
        for seed in 0..40 {
            let s = generate(Family::Biased, seed, &ScenarioParams::default());
            for (index, sp) in s.spheres.iter().enumerate() {
                let Behaviour::Biased { mean_rad_s, .. } = sp.behaviour else {
                    continue;
                };
                let past = s.lead_in(index, 60.0);
                let pts: Vec<[f64; 3]> = past.samples_m.iter().rev().copied().collect();
                let mut turned = 0.0;
                for w in pts.windows(3) {
                    let a = (w[1][1] - w[0][1]).atan2(w[1][0] - w[0][0]);
                    let b = (w[2][1] - w[1][1]).atan2(w[2][0] - w[1][0]);
                    let mut d = b - a;
                    while d > std::f64::consts::PI {
                        d -= std::f64::consts::TAU;
                    }
                    while d < -std::f64::consts::PI {
                        d += std::f64::consts::TAU;
                    }
                    turned += d;
                }
                total += 1;
                if turned * mean_rad_s > 0.0 {
                    agree += 1;
                }
            }
        }
        assert!(total >= 40, "{total} biased spheres");
        assert!(
            agree * 10 >= total * 8,
            "{agree} of {total} biased spheres turned to their side before take-off"
        );
    }
}
