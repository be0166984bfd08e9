//! The simulated fixed-wing aircraft: constant airspeed, constant altitude per leg (reached at
//! a bounded climb rate), a bank-limited turn rate, L1 path following along the current stack
//! leg and waypoint switching on an acceptance radius or on passing the waypoint.
//!
//! L1 guidance (Park, Deyst, How 2004, as in ArduPlane): the reference point is where a circle
//! of radius `L1 = damping * period * V / pi` around the aircraft meets the leg ahead (or the
//! waypoint itself when it is nearer than `L1`, or the foot of the perpendicular when the
//! aircraft is farther than `L1` from the leg); the lateral acceleration command is
//! `a = 2 V^2 / L1 * sin(eta)`, `eta` the angle from the velocity to the reference point,
//! saturated at `g tan(bank_max)`.
//!
//! # Units
//! ENU metres, metres MSL, seconds, m/s, radians counter-clockwise from east.

use serde::{Deserialize, Serialize};

use crate::geometry::{P2, add, cross, dist, dot, norm, scale, sub, unit, wrap_pi, xy};
use crate::mission::Stack;

/// Standard gravity, m/s^2.
pub const G_MPS2: f64 = 9.80665;

/// Aircraft parameters. Defaults: 20 m/s, 35 deg bank (turn radius 58 m), L1 period 17 s and
/// damping 0.75 (L1 = 81 m), acceptance radius 10 m, climb rate 4 m/s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AircraftParams {
    /// Constant airspeed = ground speed (no wind), m/s.
    pub speed_mps: f64,
    /// Maximum bank angle, degrees.
    pub max_bank_deg: f64,
    /// L1 period, seconds.
    pub l1_period_s: f64,
    /// L1 damping ratio.
    pub l1_damping: f64,
    /// A waypoint is reached within this horizontal distance, metres.
    pub acceptance_radius_m: f64,
    /// Maximum climb/descent rate, m/s.
    pub climb_rate_mps: f64,
}

impl Default for AircraftParams {
    fn default() -> Self {
        Self {
            speed_mps: 20.0,
            max_bank_deg: 35.0,
            l1_period_s: 17.0,
            l1_damping: 0.75,
            acceptance_radius_m: 10.0,
            climb_rate_mps: 4.0,
        }
    }
}

impl AircraftParams {
    /// Maximum turn rate `g tan(bank) / V`, rad/s.
    pub fn max_turn_rate_rad_s(&self) -> f64 {
        G_MPS2 * self.max_bank_deg.to_radians().tan() / self.speed_mps
    }
    /// Minimum turn radius `V^2 / (g tan(bank))`, metres.
    pub fn min_turn_radius_m(&self) -> f64 {
        self.speed_mps / self.max_turn_rate_rad_s()
    }
    /// L1 distance, metres.
    pub fn l1_distance_m(&self) -> f64 {
        self.l1_damping * self.l1_period_s * self.speed_mps / std::f64::consts::PI
    }
    /// L1 distance in seconds of flight, `damping * period / pi` (the planner's
    /// [`planner::VerifyParams::l1_s`]).
    pub fn l1_s(&self) -> f64 {
        self.l1_damping * self.l1_period_s / std::f64::consts::PI
    }
    planner::setters! {
        /// Sets the speed, m/s.
        speed_mps(speed_mps: f64);
        /// Sets the maximum bank, degrees.
        max_bank_deg(max_bank_deg: f64);
        /// Sets the waypoint acceptance radius, metres.
        acceptance_radius_m(acceptance_radius_m: f64);
        /// Sets the L1 period, seconds.
        l1_period_s(l1_period_s: f64);
    }
}

/// The aircraft's state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AircraftState {
    /// Time, mission seconds.
    pub t_s: f64,
    /// Position, ENU metres and MSL.
    pub p_m: [f64; 3],
    /// Heading, radians counter-clockwise from east.
    pub heading_rad: f64,
    /// Ground speed, m/s.
    pub speed_mps: f64,
}

/// A commanded turn that overrides path following for a while (reactive strategies).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SteerOverride {
    /// Commanded turn rate, rad/s (clipped to the aircraft's limit).
    pub turn_rate_rad_s: f64,
    /// Mission time until which the override holds.
    pub until_s: f64,
}

impl AircraftParams {
    /// The planner's view of this aircraft: cruise speed and minimum turn radius.
    pub fn planner_aircraft(&self) -> planner::Aircraft {
        planner::Aircraft {
            speed_mps: self.speed_mps,
            turn_radius_m: self.min_turn_radius_m(),
        }
    }
}

impl AircraftState {
    /// The planner's view of this state, as telemetry reports it (the simulator's heading is
    /// counter-clockwise from east; the planner's is a compass heading, clockwise from north).
    pub fn planner_state(&self) -> planner::AircraftState {
        planner::AircraftState {
            p_m: [self.p_m[0], self.p_m[1]],
            alt_m: self.p_m[2],
            heading_rad: std::f64::consts::FRAC_PI_2 - self.heading_rad,
            speed_mps: self.speed_mps,
            t_s: self.t_s,
        }
    }
}

/// The autopilot: follows the stack with L1 guidance.
#[derive(Debug, Clone, PartialEq)]
pub struct Autopilot {
    /// Parameters.
    pub params: AircraftParams,
    /// State.
    pub state: AircraftState,
    /// Start of the current leg (the point the aircraft left when the target became current).
    pub leg_start_m: P2,
    /// Optional steering override.
    pub steer: Option<SteerOverride>,
}

impl Autopilot {
    /// An aircraft at `p_m` heading toward `toward_m`.
    pub fn new(params: AircraftParams, p_m: [f64; 3], toward_m: P2) -> Self {
        let d = sub(toward_m, xy(p_m));
        let heading_rad = d[1].atan2(d[0]);
        Self {
            params,
            state: AircraftState {
                t_s: 0.0,
                p_m,
                heading_rad,
                speed_mps: params.speed_mps,
            },
            leg_start_m: xy(p_m),
            steer: None,
        }
    }

    /// Lateral acceleration command of L1 guidance toward the leg `leg_start_m -> target`,
    /// m/s^2, positive to the left, saturated.
    pub fn l1_lateral_accel_mps2(&self, target_m: P2) -> f64 {
        let v = self.params.speed_mps;
        let l1 = self.params.l1_distance_m();
        let pos = xy(self.state.p_m);
        let leg = sub(target_m, self.leg_start_m);
        let leg_len = norm(leg);
        let reference = if leg_len < 1e-6 || dist(pos, target_m) <= l1 {
            target_m
        } else {
            let u = scale(leg, 1.0 / leg_len);
            let r = sub(pos, self.leg_start_m);
            let along = dot(r, u);
            let xt = cross(u, r);
            if xt.abs() >= l1 {
                add(self.leg_start_m, scale(u, along.clamp(0.0, leg_len)))
            } else {
                let a = (along + (l1 * l1 - xt * xt).sqrt()).min(leg_len);
                add(self.leg_start_m, scale(u, a))
            }
        };
        let to_ref = sub(reference, pos);
        let vel = [self.state.heading_rad.cos(), self.state.heading_rad.sin()];
        let eta = wrap_pi(to_ref[1].atan2(to_ref[0]) - vel[1].atan2(vel[0]));
        let a_max = G_MPS2 * self.params.max_bank_deg.to_radians().tan();
        if eta.abs() > std::f64::consts::FRAC_PI_2 {
            return a_max.copysign(eta);
        }
        (2.0 * v * v / l1 * eta.sin()).clamp(-a_max, a_max)
    }

    /// Advances by `dt_s` following `stack` (switching waypoints as needed). Returns the
    /// indices of items reached during the step.
    pub fn step(&mut self, stack: &mut Stack, dt_s: f64) -> Vec<usize> {
        let mut reached = Vec::new();
        let omega_max = self.params.max_turn_rate_rad_s();
        let target = stack.target().copied();
        let omega = match (self.steer, target) {
            (Some(s), _) if s.until_s > self.state.t_s => {
                s.turn_rate_rad_s.clamp(-omega_max, omega_max)
            }
            (_, Some(t)) => self.l1_lateral_accel_mps2(t.p_m) / self.params.speed_mps,
            (_, None) => 0.0,
        };
        if self.steer.is_some_and(|s| s.until_s <= self.state.t_s) {
            self.steer = None;
        }
        let v = self.params.speed_mps;
        let mid = self.state.heading_rad + 0.5 * omega * dt_s;
        self.state.p_m[0] += v * dt_s * mid.cos();
        self.state.p_m[1] += v * dt_s * mid.sin();
        self.state.heading_rad = wrap_pi(self.state.heading_rad + omega * dt_s);
        if let Some(t) = target {
            let dz = t.alt_m - self.state.p_m[2];
            let max_dz = self.params.climb_rate_mps * dt_s;
            self.state.p_m[2] += dz.clamp(-max_dz, max_dz);
        }
        self.state.t_s += dt_s;
        // waypoint switching (at most a couple per step)
        for _ in 0..4 {
            let Some(t) = stack.target().copied() else {
                break;
            };
            let pos = xy(self.state.p_m);
            let tp = t.p_m;
            let within = dist(pos, tp) <= self.params.acceptance_radius_m;
            let leg = sub(tp, self.leg_start_m);
            let passed = norm(leg) > 1e-6 && dot(sub(pos, tp), unit(leg)) > 0.0;
            if within || passed {
                reached.push(stack.current);
                stack.current += 1;
                self.leg_start_m = tp;
            } else {
                break;
            }
        }
        reached
    }

    /// Installs a new stack from a strategy. When the target changes, the new leg starts at
    /// the aircraft's position (as an autopilot does after a mission upload).
    pub fn replace_stack(&mut self, stack: &mut Stack, new_stack: Stack) {
        let old = stack.target().map(|t| t.p_m);
        let new = new_stack.target().map(|t| t.p_m);
        if old != new {
            self.leg_start_m = xy(self.state.p_m);
        }
        *stack = new_stack;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::StackItem;

    #[test]
    fn the_default_aircraft_turns_no_tighter_than_its_bank_allows() {
        let p = AircraftParams::default();
        // 20^2 / (9.80665 * tan 35deg) = 400 / 6.8666 = 58.25 m
        assert!((p.min_turn_radius_m() - 58.25).abs() < 0.05);
        // L1 = 0.75 * 17 * 20 / pi = 81.17 m
        assert!((p.l1_distance_m() - 81.17).abs() < 0.01);
    }

    #[test]
    fn l1_guidance_converges_onto_a_leg_and_reaches_the_waypoint() {
        // start 100 m north of a west-east leg, heading east; target 2 km east on the leg
        let params = AircraftParams::default();
        let mut ap = Autopilot::new(params, [0.0, 100.0, 100.0], [1.0, 100.0]);
        ap.leg_start_m = [0.0, 0.0];
        let mut stack = Stack {
            items: vec![StackItem::mission(0, [2000.0, 0.0], 100.0)],
            current: 0,
        };
        let mut max_xt_late: f64 = 0.0;
        let mut steps = 0;
        while stack.current == 0 && steps < 2000 {
            ap.step(&mut stack, 0.1);
            steps += 1;
            if ap.state.p_m[0] > 800.0 {
                max_xt_late = max_xt_late.max(ap.state.p_m[1].abs());
            }
        }
        assert_eq!(stack.current, 1, "waypoint reached");
        assert!(max_xt_late < 2.0, "cross-track after 800 m: {max_xt_late}");
        // 2 km at 20 m/s is 100 s; the convergence adds a little
        assert!(steps < 1060, "{steps}");
    }

    #[test]
    fn the_autopilot_goes_on_to_the_next_item_at_its_acceptance_radius() {
        // East along y = 0 toward (1000, 0), then a right angle north: the distance left to
        // the first item when the autopilot switches is the acceptance radius (within a step).
        for radius in [10.0, 90.0] {
            let params = AircraftParams::default().acceptance_radius_m(radius);
            let mut ap = Autopilot::new(params, [0.0, 0.0, 100.0], [1.0, 0.0]);
            ap.leg_start_m = [0.0, 0.0];
            let mut stack = Stack {
                items: vec![
                    StackItem::mission(0, [1000.0, 0.0], 100.0),
                    StackItem::mission(1, [1000.0, 1000.0], 100.0),
                ],
                current: 0,
            };
            let mut steps = 0;
            while stack.current == 0 && steps < 2000 {
                ap.step(&mut stack, 0.1);
                steps += 1;
            }
            let left = dist(xy(ap.state.p_m), [1000.0, 0.0]);
            // One 0.1 s step is 2 m at 20 m/s.
            assert!(left <= radius && left > radius - 2.5, "{radius}: {left}");
        }
    }
}
