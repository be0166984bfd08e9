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
}

impl Default for TelemetryParams {
    fn default() -> Self {
        Self {
            rate_hz: 2.0,
            noise_sigma_m: 1.0,
            dropout_prob: 0.05,
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
    scenario
        .spheres
        .iter()
        .map(|s| {
            let mut out = Vec::with_capacity(n + 1);
            for i in 0..=n {
                let t_s = i as f64 * dt;
                let lost = rng.random::<f64>() < params.dropout_prob;
                let mut p_m = s.track.at(t_s);
                for c in &mut p_m {
                    *c += noise.sample(&mut rng);
                }
                if !lost {
                    out.push(ObstacleObservation {
                        t_s,
                        p_m,
                        radius_m: s.radius_m,
                    });
                }
            }
            out
        })
        .collect()
}
