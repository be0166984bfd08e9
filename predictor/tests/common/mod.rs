//! Seeded synthetic obstacle tracks for the characterization tests: constant speed, a turn
//! rate redrawn at every whole second (the predictor's default decision clock), exact arc
//! integration, observations at `rate_hz`.
#![allow(dead_code)]

use predictor::Observation;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How the synthetic obstacle picks its next turn rate (rad/s, left positive).
#[derive(Debug, Clone, Copy)]
pub enum Behaviour {
    /// Never turns.
    Straight,
    /// Uniform in [-w, w] every second.
    Uniform { w: f64 },
    /// Memoryless but biased: half the time nearly straight (|omega| < w/9), else uniform.
    Biased { w: f64 },
    /// Memory: after a left turn (> w/3) a right turn (in [-w, -w/3]) with probability 0.8,
    /// and the mirror; otherwise uniform.
    Zigzag { w: f64 },
    /// Stands still.
    Stationary,
    /// Turns steadily at `w` (a constant-turn-rate mover).
    Circling { w: f64 },
    /// Leans one way: `mean` plus uniform in [-spread, spread] every second (the
    /// simulator's biased turners, a turn-rate mean of 0.05-0.15 rad/s).
    Leaning { mean: f64, spread: f64 },
}

pub fn next_turn(b: Behaviour, prev: f64, rng: &mut ChaCha8Rng) -> f64 {
    match b {
        Behaviour::Straight | Behaviour::Stationary => 0.0,
        Behaviour::Circling { w } => w,
        Behaviour::Leaning { mean, spread } => mean + rng.random_range(-spread..spread),
        Behaviour::Uniform { w } => rng.random_range(-w..w),
        Behaviour::Biased { w } => {
            if rng.random::<f64>() < 0.5 {
                rng.random_range(-w / 9.0..w / 9.0)
            } else {
                rng.random_range(-w..w)
            }
        }
        Behaviour::Zigzag { w } => {
            let alternate = rng.random::<f64>() < 0.8;
            if prev > w / 3.0 && alternate {
                rng.random_range(-w..-w / 3.0)
            } else if prev < -w / 3.0 && alternate {
                rng.random_range(w / 3.0..w)
            } else {
                rng.random_range(-w..w)
            }
        }
    }
}

/// A generated track: observations and the state needed to continue it.
#[derive(Debug, Clone)]
pub struct Generator {
    pub b: Behaviour,
    pub speed_mps: f64,
    pub radius_m: f64,
    pub t_s: f64,
    pub p: [f64; 2],
    pub heading_rad: f64,
    pub omega: f64,
    pub rng: ChaCha8Rng,
}

impl Generator {
    pub fn new(b: Behaviour, speed_mps: f64, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let heading_rad = rng.random_range(0.0..std::f64::consts::TAU);
        let omega = next_turn(b, 0.0, &mut rng);
        let speed_mps = if matches!(b, Behaviour::Stationary) {
            0.0
        } else {
            speed_mps
        };
        Self {
            b,
            speed_mps,
            radius_m: 9.144,
            t_s: 0.0,
            p: [0.0, 0.0],
            heading_rad,
            omega,
            rng,
        }
    }

    /// Advances by `h` seconds, never across a whole second (decisions happen there).
    fn step(&mut self, h: f64) {
        let (w, v) = (self.omega, self.speed_mps);
        let th = self.heading_rad;
        if w.abs() > 1e-12 {
            self.p[0] += v / w * ((th + w * h).sin() - th.sin());
            self.p[1] += v / w * (th.cos() - (th + w * h).cos());
        } else {
            self.p[0] += v * h * th.cos();
            self.p[1] += v * h * th.sin();
        }
        self.heading_rad += w * h;
        self.t_s += h;
        let frac = self.t_s - self.t_s.round();
        if frac.abs() < 1e-9 {
            self.t_s = self.t_s.round();
            self.omega = next_turn(self.b, self.omega, &mut self.rng);
        }
    }

    /// Advances by `dt_s` (a multiple of 0.1 s) and returns the position.
    pub fn advance(&mut self, dt_s: f64) -> [f64; 2] {
        let n = (dt_s / 0.1).round() as usize;
        for _ in 0..n {
            self.step(0.1);
        }
        self.p
    }

    pub fn observation(&self) -> Observation {
        Observation {
            t_s: self.t_s,
            p_m: self.p,
            alt_m: 60.0,
            radius_m: self.radius_m,
        }
    }

    /// `duration_s` of 10 Hz observations starting with the current state.
    pub fn track(&mut self, duration_s: f64) -> Vec<Observation> {
        let n = (duration_s * 10.0).round() as usize;
        let mut out = vec![self.observation()];
        for _ in 0..n {
            self.advance(0.1);
            out.push(self.observation());
        }
        out
    }
}
