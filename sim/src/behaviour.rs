//! Moving-obstacle behaviours and their ground-truth trajectories.
//!
//! Turning behaviours fly at constant speed and altitude and redraw their turn rate at a
//! decision interval (1 s by default, the same interval the predictor's histograms use, so
//! "memory" means one turn decision depending on the previous one). They implement the four
//! kinds of motion the predictor's stages are built for (seed 002): straight with rare turns
//! (stage 2 and constant-velocity friendly), uniformly random turning (stage 2), biased turning
//! from a skewed distribution (stage 3), patterned turning that depends on the previous turn
//! (stage 4). The fifth behaviour is the judges' closed-loop spline tour ([`crate::spline`]).
//!
//! A soft containment keeps turning obstacles near the mission: outside a containment circle
//! and heading outward, an obstacle turns back toward the centre at its maximum rate.
//!
//! # Units
//! ENU metres, metres MSL, seconds, rad/s (counter-clockwise positive).

use rand::{Rng, RngExt};
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::geometry::{P2, dot, sub};
use crate::spline::SplineTour;

/// The behaviour families, as labels for reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BehaviourKind {
    /// Straight flight with rare turns.
    Straight,
    /// Turn rate redrawn uniformly every decision.
    Random,
    /// Turn rate drawn from a skewed distribution.
    Biased,
    /// Turn rate depends on the previous decision.
    Patterned,
    /// Closed-loop spline tour through waypoints, as the judges' server flew them.
    Spline,
}

impl BehaviourKind {
    /// All kinds, in report order.
    pub const ALL: [BehaviourKind; 5] = [
        Self::Straight,
        Self::Random,
        Self::Biased,
        Self::Patterned,
        Self::Spline,
    ];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Straight => "straight",
            Self::Random => "random",
            Self::Biased => "biased",
            Self::Patterned => "patterned",
            Self::Spline => "spline",
        }
    }
}

/// A behaviour with its parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Behaviour {
    /// Straight, with probability `turn_prob` per decision of starting a turn at
    /// `+-turn_rate_rad_s` that lasts 3 to 6 decisions.
    Straight {
        /// Probability per decision of starting a turn.
        turn_prob: f64,
        /// Magnitude of the turn rate during a turn.
        turn_rate_rad_s: f64,
    },
    /// Turn rate uniform in `[-max, max]`, redrawn each decision.
    Random {
        /// Maximum turn rate.
        max_turn_rate_rad_s: f64,
    },
    /// Turn rate normal around `mean` with `sigma`, clipped to `+-max`.
    Biased {
        /// Mean turn rate (its sign is the favoured side).
        mean_rad_s: f64,
        /// Spread of the turn rate.
        sigma_rad_s: f64,
        /// Clip.
        max_turn_rate_rad_s: f64,
    },
    /// Three turn states (left, straight, right) at `+-turn_rate_rad_s` with a Markov
    /// transition: after a turn, the opposite turn with probability `follow_prob` (a zigzag);
    /// after straight, left or right evenly.
    Patterned {
        /// Magnitude of a turn.
        turn_rate_rad_s: f64,
        /// Probability of following the pattern.
        follow_prob: f64,
    },
    /// The judges' closed-loop tour.
    Spline(SplineTour),
}

impl Behaviour {
    /// The behaviour's label.
    pub fn kind(&self) -> BehaviourKind {
        match self {
            Self::Straight { .. } => BehaviourKind::Straight,
            Self::Random { .. } => BehaviourKind::Random,
            Self::Biased { .. } => BehaviourKind::Biased,
            Self::Patterned { .. } => BehaviourKind::Patterned,
            Self::Spline(_) => BehaviourKind::Spline,
        }
    }

    /// The behaviour flown backward in time: the same path traversed the other way curves
    /// the other way relative to its heading, so a favoured turn side flips (`Biased`); the
    /// symmetric behaviours are their own mirror. Used to draw a turning obstacle's flight
    /// before `t = 0` ([`crate::scenario::Scenario::lead_in`]).
    pub fn mirrored(&self) -> Self {
        match self {
            Self::Biased {
                mean_rad_s,
                sigma_rad_s,
                max_turn_rate_rad_s,
            } => Self::Biased {
                mean_rad_s: -mean_rad_s,
                sigma_rad_s: *sigma_rad_s,
                max_turn_rate_rad_s: *max_turn_rate_rad_s,
            },
            other => other.clone(),
        }
    }
}

/// A ground-truth trajectory sampled every `dt_s` from `t = 0`; positions between samples are
/// linear interpolations (the sampling step is small next to any obstacle's radius).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    /// Sampling step, seconds.
    pub dt_s: f64,
    /// Positions, ENU metres and MSL.
    pub samples_m: Vec<[f64; 3]>,
}

impl Trajectory {
    /// Position at `t_s` (clamped to the sampled span).
    pub fn at(&self, t_s: f64) -> [f64; 3] {
        let last = self.samples_m.len() - 1;
        let x = (t_s / self.dt_s).max(0.0);
        let i = (x.floor() as usize).min(last);
        if i >= last {
            return self.samples_m[last];
        }
        let f = x - i as f64;
        let (a, b) = (self.samples_m[i], self.samples_m[i + 1]);
        [
            a[0] + (b[0] - a[0]) * f,
            a[1] + (b[1] - a[1]) * f,
            a[2] + (b[2] - a[2]) * f,
        ]
    }

    /// Duration covered, seconds.
    pub fn duration_s(&self) -> f64 {
        (self.samples_m.len() - 1) as f64 * self.dt_s
    }
}

/// Where a turning obstacle starts and how it is kept near the mission.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurningStart {
    /// Start position, ENU metres and MSL.
    pub p_m: [f64; 3],
    /// Start heading, radians counter-clockwise from east.
    pub heading_rad: f64,
    /// Constant speed.
    pub speed_mps: f64,
    /// Centre of the containment circle.
    pub contain_center_m: P2,
    /// Radius of the containment circle.
    pub contain_radius_m: f64,
}

/// Decision interval of the turning behaviours, seconds.
pub const DECISION_INTERVAL_S: f64 = 1.0;

/// Samples `behaviour` every `dt_s` for `duration_s`.
pub fn trajectory<R: Rng + ?Sized>(
    behaviour: &Behaviour,
    start: &TurningStart,
    duration_s: f64,
    dt_s: f64,
    rng: &mut R,
) -> Trajectory {
    let steps = (duration_s / dt_s).ceil() as usize;
    if let Behaviour::Spline(tour) = behaviour {
        let samples_m = (0..=steps)
            .map(|i| tour.position(i as f64 * dt_s))
            .collect();
        return Trajectory { dt_s, samples_m };
    }
    let per_decision = (DECISION_INTERVAL_S / dt_s).round().max(1.0) as usize;
    let jitter = Normal::new(0.0, 0.02).unwrap();
    let mut p = start.p_m;
    let mut heading = start.heading_rad;
    let mut omega = 0.0;
    // behaviour memory: remaining steps of a straight-flight turn; patterned state -1/0/1
    let mut turn_left = 0u32;
    let mut state: i32 = 0;
    let max_rate = match behaviour {
        Behaviour::Straight {
            turn_rate_rad_s, ..
        } => *turn_rate_rad_s,
        Behaviour::Random {
            max_turn_rate_rad_s,
        } => *max_turn_rate_rad_s,
        Behaviour::Biased {
            max_turn_rate_rad_s,
            ..
        } => *max_turn_rate_rad_s,
        Behaviour::Patterned {
            turn_rate_rad_s, ..
        } => *turn_rate_rad_s,
        Behaviour::Spline(_) => 0.0,
    }
    .max(0.15);
    let mut samples_m = Vec::with_capacity(steps + 1);
    samples_m.push(p);
    for i in 0..steps {
        if i % per_decision == 0 {
            // every behaviour draws its own decision first (keeps the random stream aligned
            // whether or not containment overrides it)
            omega = match behaviour {
                Behaviour::Straight {
                    turn_prob,
                    turn_rate_rad_s,
                } => {
                    if turn_left > 0 {
                        turn_left -= 1;
                        omega
                    } else if rng.random::<f64>() < *turn_prob {
                        turn_left = rng.random_range(2..6);
                        if rng.random::<bool>() {
                            *turn_rate_rad_s
                        } else {
                            -*turn_rate_rad_s
                        }
                    } else {
                        0.0
                    }
                }
                Behaviour::Random {
                    max_turn_rate_rad_s,
                } => rng.random_range(-*max_turn_rate_rad_s..=*max_turn_rate_rad_s),
                Behaviour::Biased {
                    mean_rad_s,
                    sigma_rad_s,
                    max_turn_rate_rad_s,
                } => {
                    let d = Normal::new(*mean_rad_s, sigma_rad_s.max(1e-9)).unwrap();
                    d.sample(rng)
                        .clamp(-*max_turn_rate_rad_s, *max_turn_rate_rad_s)
                }
                Behaviour::Patterned {
                    turn_rate_rad_s,
                    follow_prob,
                } => {
                    let u = rng.random::<f64>();
                    state = match state {
                        0 => {
                            if u < 0.1 {
                                0
                            } else if u < 0.55 {
                                1
                            } else {
                                -1
                            }
                        }
                        s => {
                            if u < *follow_prob {
                                -s
                            } else if u < *follow_prob + (1.0 - follow_prob) / 2.0 {
                                0
                            } else {
                                s
                            }
                        }
                    };
                    f64::from(state) * turn_rate_rad_s + jitter.sample(rng)
                }
                Behaviour::Spline(_) => 0.0,
            };
            let off = sub([p[0], p[1]], start.contain_center_m);
            let dir = [heading.cos(), heading.sin()];
            if dot(off, off) > start.contain_radius_m.powi(2) && dot(off, dir) > 0.0 {
                // turn toward the centre: left if the centre is to the left of the heading
                let to_c = [-off[0], -off[1]];
                let left = dir[0] * to_c[1] - dir[1] * to_c[0] > 0.0;
                omega = if left { max_rate } else { -max_rate };
            }
        }
        let mid = heading + 0.5 * omega * dt_s;
        p[0] += start.speed_mps * dt_s * mid.cos();
        p[1] += start.speed_mps * dt_s * mid.sin();
        heading += omega * dt_s;
        samples_m.push(p);
    }
    Trajectory { dt_s, samples_m }
}
