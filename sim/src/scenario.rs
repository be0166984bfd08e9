//! Seeded scenarios within the SUAS rules: a fly-zone polygon, mission waypoints, up to 10
//! cylinders (radius 30-300 ft, top 30-750 ft MSL) and up to 10 moving spheres (radius
//! 30-300 ft, speed 0-40 kt) with a chosen behaviour family; or moving spheres generated for
//! a real mission.
//!
//! Cylinders are placed on or near mission legs (as judges did, to force avoidance) but never
//! over a waypoint; spheres fly around the mission's altitudes so that they matter.
//!
//! # Units
//! ENU metres, metres MSL, seconds, m/s. Ground at 0 m MSL.

use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::behaviour::{Behaviour, BehaviourKind, Trajectory, TurningStart, trajectory};
use crate::geometry::{P2, dist, point_in_polygon, xy};
use crate::mission::{Cylinder, FlyZone, Mission, Waypoint, bounds_m, fly_zone, straight_length_m};
use crate::spline::SplineTour;

/// Feet to metres.
pub const FT: f64 = 0.3048;
/// Knots to m/s.
pub const KT: f64 = 0.514444;
/// Rules: obstacle radius range, metres (30-300 ft).
pub const RADIUS_RANGE_M: (f64, f64) = (30.0 * FT, 300.0 * FT);
/// Rules: cylinder top range, metres MSL (30-750 ft).
pub const CYL_TOP_RANGE_M: (f64, f64) = (30.0 * FT, 750.0 * FT);
/// Rules: sphere speed range, m/s (0-40 kt).
pub const SPEED_RANGE_MPS: (f64, f64) = (0.0, 40.0 * KT);
/// Step of the ground-truth trajectories, seconds.
pub const TRUTH_DT_S: f64 = 0.1;

/// Which behaviours the moving spheres of a scenario use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// Each sphere draws one of the five behaviours.
    Mixed,
    /// All spheres fly straight with rare turns.
    Straight,
    /// All spheres turn randomly.
    Random,
    /// All spheres turn with a bias.
    Biased,
    /// All spheres turn in a pattern (memory).
    Patterned,
    /// All spheres fly the judges' spline tours.
    Spline,
    /// Cylinders only, no moving spheres.
    Static,
}

impl Family {
    /// All families.
    pub const ALL: [Family; 7] = [
        Self::Mixed,
        Self::Straight,
        Self::Random,
        Self::Biased,
        Self::Patterned,
        Self::Spline,
        Self::Static,
    ];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Mixed => "mixed",
            Self::Straight => "straight",
            Self::Random => "random",
            Self::Biased => "biased",
            Self::Patterned => "patterned",
            Self::Spline => "spline",
            Self::Static => "static",
        }
    }

    /// Parses a lower-case name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == s)
    }
}

/// Counts and sizes of generated scenarios. Defaults: 5-7 waypoints, 2-6 cylinders,
/// 3-6 spheres, fly zone of radius 650-950 m, aircraft speed for the time limit 20 m/s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioParams {
    /// Inclusive range of mission waypoints.
    pub waypoints: (usize, usize),
    /// Inclusive range of cylinders (rules: at most 10).
    pub cylinders: (usize, usize),
    /// Inclusive range of moving spheres (rules: at most 10).
    pub spheres: (usize, usize),
    /// Range of the fly zone's radius, metres.
    pub zone_radius_m: (f64, f64),
    /// Aircraft speed used to size the run's time limit, m/s.
    pub aircraft_speed_mps: f64,
    /// Fraction of cylinders placed on a mission leg.
    pub cylinders_on_legs: f64,
}

impl Default for ScenarioParams {
    fn default() -> Self {
        Self {
            waypoints: (5, 7),
            cylinders: (2, 6),
            spheres: (3, 6),
            zone_radius_m: (650.0, 950.0),
            aircraft_speed_mps: 20.0,
            cylinders_on_legs: 0.6,
        }
    }
}

/// One moving sphere with its ground truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MovingSphere {
    /// Radius, metres.
    pub radius_m: f64,
    /// (Average) speed, m/s.
    pub speed_mps: f64,
    /// Behaviour and parameters.
    pub behaviour: Behaviour,
    /// Ground-truth positions.
    pub track: Trajectory,
}

/// A complete scenario: mission plus moving spheres, reproducible from `(family, seed)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scenario {
    /// Family it was drawn from.
    pub family: Family,
    /// Seed it was drawn with.
    pub seed: u64,
    /// The mission (the planner's own type).
    pub mission: Mission,
    /// Where the aircraft starts (take-off or hand-over point), ENU metres and MSL.
    pub start_m: [f64; 3],
    /// Moving spheres.
    pub spheres: Vec<MovingSphere>,
    /// Time limit of a run (and span of the truth), seconds.
    pub duration_s: f64,
}

/// Generates the scenario `(family, seed)`.
pub fn generate(family: Family, seed: u64, params: &ScenarioParams) -> Scenario {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5CE7_A210);
    let (mission, start_m) = random_mission(params, &mut rng);
    let n = if family == Family::Static {
        0
    } else {
        rng.random_range(params.spheres.0..=params.spheres.1)
    };
    let s = Scenario::without_spheres(family, seed, mission, start_m);
    add_moving_spheres(s, n, params.aircraft_speed_mps, &mut rng)
}

/// Adds `n_spheres` moving spheres of `family` to a given (e.g. real) mission flown from
/// `start_m` (ENU metres and MSL).
pub fn with_moving_spheres(
    mission: Mission,
    start_m: [f64; 3],
    family: Family,
    seed: u64,
    n_spheres: usize,
    aircraft_speed_mps: f64,
) -> Scenario {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0B57_AC1E);
    let s = Scenario::without_spheres(family, seed, mission, start_m);
    add_moving_spheres(s, n_spheres.min(10), aircraft_speed_mps, &mut rng)
}

impl Scenario {
    /// Ground truth of sphere `index` before the run starts: sample `k` is where it was at
    /// `t = -k * dt_s` (sample 0 is its start), over `lead_in_s` seconds. A spline tour is
    /// periodic, so its past is its own tour; a turning sphere's past is flown backward from
    /// its start (reversed heading, mirrored behaviour, the same containment) with its own
    /// random stream, so the scenario from `t = 0` on is the same with or without a lead-in.
    /// Used for obstacle telemetry received before take-off
    /// ([`crate::telemetry::TelemetryParams::lead_in_s`]).
    ///
    /// # Panics
    /// When `index` is not a sphere of the scenario.
    pub fn lead_in(&self, index: usize, lead_in_s: f64) -> Trajectory {
        let sp = &self.spheres[index];
        let dt_s = sp.track.dt_s;
        let steps = (lead_in_s.max(0.0) / dt_s).ceil() as usize;
        if let Behaviour::Spline(tour) = &sp.behaviour {
            let samples_m = (0..=steps)
                .map(|k| tour.position(-(k as f64) * dt_s))
                .collect();
            return Trajectory { dt_s, samples_m };
        }
        let p0 = sp.track.samples_m[0];
        let p1 = sp.track.samples_m.get(1).copied().unwrap_or(p0);
        let heading_rad = (p1[1] - p0[1]).atan2(p1[0] - p0[0]);
        let (center_m, radius_m) = containment(&self.mission);
        let start = TurningStart {
            p_m: p0,
            heading_rad: heading_rad + std::f64::consts::PI,
            speed_mps: sp.speed_mps,
            contain_center_m: center_m,
            contain_radius_m: radius_m,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(
            self.seed ^ 0x1EAD_0000_0000 ^ (index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        );
        trajectory(
            &sp.behaviour.mirrored(),
            &start,
            lead_in_s.max(0.0),
            dt_s,
            &mut rng,
        )
    }

    /// The mission flown from `start_m` with no moving sphere yet (and no time limit).
    fn without_spheres(family: Family, seed: u64, mission: Mission, start_m: [f64; 3]) -> Self {
        Self {
            family,
            seed,
            mission,
            start_m,
            spheres: Vec::new(),
            duration_s: 0.0,
        }
    }
}

/// Sets the time limit (three times the straight route at `aircraft_speed_mps`, plus a
/// minute) and draws `n_spheres` moving spheres of the scenario's family over it.
fn add_moving_spheres(
    mut s: Scenario,
    n_spheres: usize,
    aircraft_speed_mps: f64,
    rng: &mut ChaCha8Rng,
) -> Scenario {
    s.duration_s =
        (3.0 * straight_length_m(&s.mission, s.start_m) / aircraft_speed_mps + 60.0).ceil();
    if s.family != Family::Static {
        s.spheres = (0..n_spheres)
            .map(|_| random_sphere(&s.mission, s.start_m, s.family, s.duration_s, rng))
            .collect();
    }
    s
}

fn random_mission<R: Rng + ?Sized>(params: &ScenarioParams, rng: &mut R) -> (Mission, [f64; 3]) {
    // star-shaped zone: 10 vertices at jittered angles and radii
    let r0 = rng.random_range(params.zone_radius_m.0..params.zone_radius_m.1);
    let nv = 10;
    let fly_zone_m: Vec<P2> = (0..nv)
        .map(|i| {
            let a = (i as f64 + rng.random_range(-0.3..0.3)) * std::f64::consts::TAU / nv as f64;
            let r = r0 * rng.random_range(0.75..1.1);
            [r * a.cos(), r * a.sin()]
        })
        .collect();
    let inner = |p: P2, zone: &[P2]| {
        // inside the zone with a 60 m margin from every edge
        point_in_polygon(p, zone) && crate::geometry::distance_to_polygon_boundary(p, zone) > 60.0
    };
    let zone = fly_zone_m.clone();
    let sample_inside = |rng: &mut R| loop {
        let p = [rng.random_range(-r0..r0), rng.random_range(-r0..r0)];
        if inner(p, &zone) {
            return p;
        }
    };
    let alt = |rng: &mut R| (rng.random_range(200.0..500.0) * FT / 10.0).round() * 10.0;
    let start = sample_inside(rng);
    let start_m = [start[0], start[1], 100.0];
    let nw = rng.random_range(params.waypoints.0..=params.waypoints.1);
    let mut waypoints_m: Vec<[f64; 3]> = Vec::with_capacity(nw);
    let mut prev = start;
    while waypoints_m.len() < nw {
        let p = sample_inside(rng);
        if dist(p, prev) > 300.0 && dist(p, prev) < 1200.0 {
            waypoints_m.push([p[0], p[1], alt(rng)]);
            prev = p;
        }
    }
    let mut mission = Mission {
        fly_zones: vec![FlyZone {
            boundary_m: fly_zone_m,
            alt_min_m: 100.0 * FT,
            alt_max_m: 750.0 * FT,
        }],
        waypoints: waypoints_m
            .iter()
            .map(|w| Waypoint {
                p_m: [w[0], w[1]],
                alt_m: w[2],
            })
            .collect(),
        cylinders: vec![],
    };
    let nc = rng
        .random_range(params.cylinders.0..=params.cylinders.1)
        .min(10);
    let mut tries = 0;
    while mission.cylinders.len() < nc && tries < 1000 {
        tries += 1;
        let radius_m = rng.random_range(RADIUS_RANGE_M.0..RADIUS_RANGE_M.1);
        let top_m = rng.random_range(CYL_TOP_RANGE_M.0..CYL_TOP_RANGE_M.1);
        let center_m = if rng.random::<f64>() < params.cylinders_on_legs {
            let k = rng.random_range(0..mission.waypoints.len());
            let a = if k == 0 {
                xy(start_m)
            } else {
                mission.waypoints[k - 1].p_m
            };
            let b = mission.waypoints[k].p_m;
            let f = rng.random_range(0.25..0.75);
            let d = crate::geometry::unit(crate::geometry::sub(b, a));
            let off = rng.random_range(-0.6..0.6) * radius_m;
            [
                a[0] + (b[0] - a[0]) * f - d[1] * off,
                a[1] + (b[1] - a[1]) * f + d[0] * off,
            ]
        } else {
            sample_inside(rng)
        };
        let clear_of_points = std::iter::once(xy(start_m))
            .chain(mission.waypoints.iter().map(|w| w.p_m))
            .all(|w| dist(w, center_m) > radius_m + 40.0);
        let clear_of_others = mission
            .cylinders
            .iter()
            .all(|c| dist(c.center_m, center_m) > c.radius_m + radius_m + 30.0);
        if clear_of_points && clear_of_others && point_in_polygon(center_m, fly_zone(&mission)) {
            mission.cylinders.push(Cylinder {
                center_m,
                radius_m,
                top_m,
            });
        }
    }
    (mission, start_m)
}

/// The containment circle of the mission's turning spheres: centre and radius (90% of the
/// larger half-extent of the mission's bounds). Outside it and heading outward, a turning
/// sphere turns back toward the centre at its largest turn rate ([`crate::behaviour`]); the
/// prediction report scores the windows where that happens apart.
pub fn containment(mission: &Mission) -> (P2, f64) {
    let (lo, hi) = bounds_m(mission);
    let center = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let half = [(hi[0] - lo[0]) / 2.0, (hi[1] - lo[1]) / 2.0];
    (center, half[0].max(half[1]) * 0.9)
}

fn random_sphere<R: Rng + ?Sized>(
    mission: &Mission,
    start_m: [f64; 3],
    family: Family,
    duration_s: f64,
    rng: &mut R,
) -> MovingSphere {
    let kind = match family {
        Family::Mixed | Family::Static => BehaviourKind::ALL[rng.random_range(0..5)],
        Family::Straight => BehaviourKind::Straight,
        Family::Random => BehaviourKind::Random,
        Family::Biased => BehaviourKind::Biased,
        Family::Patterned => BehaviourKind::Patterned,
        Family::Spline => BehaviourKind::Spline,
    };
    let radius_m = rng.random_range(RADIUS_RANGE_M.0..RADIUS_RANGE_M.1);
    // speeds mostly in the upper half of the rules' range: slow obstacles are trivial
    let speed_mps = rng.random_range(0.25 * SPEED_RANGE_MPS.1..SPEED_RANGE_MPS.1);
    let (lo, hi) = bounds_m(mission);
    let center = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let half = [(hi[0] - lo[0]) / 2.0, (hi[1] - lo[1]) / 2.0];
    let start_xy = start_m;
    // most points near a mission leg (within 200 m of it), the rest anywhere in the bounds
    let legs: Vec<(P2, P2)> = std::iter::once(xy(start_m))
        .chain(mission.waypoints.iter().map(|w| w.p_m))
        .collect::<Vec<_>>()
        .windows(2)
        .map(|w| (w[0], w[1]))
        .collect();
    let pick_xy = |rng: &mut R| loop {
        let p = if rng.random::<f64>() < 0.7 && !legs.is_empty() {
            let (a, b) = legs[rng.random_range(0..legs.len())];
            let f = rng.random_range(0.0..1.0);
            [
                a[0] + (b[0] - a[0]) * f + rng.random_range(-200.0..200.0),
                a[1] + (b[1] - a[1]) * f + rng.random_range(-200.0..200.0),
            ]
        } else {
            [
                center[0] + rng.random_range(-half[0]..half[0]),
                center[1] + rng.random_range(-half[1]..half[1]),
            ]
        };
        if dist(p, xy(start_xy)) > 250.0 + radius_m {
            return p;
        }
    };
    let mission_alt = |rng: &mut R| {
        let w = mission.waypoints[rng.random_range(0..mission.waypoints.len())];
        w.alt_m + rng.random_range(-0.5..0.5) * radius_m
    };
    let behaviour = match kind {
        BehaviourKind::Straight => Behaviour::Straight {
            turn_prob: 0.02,
            turn_rate_rad_s: rng.random_range(0.1..0.3),
        },
        BehaviourKind::Random => Behaviour::Random {
            max_turn_rate_rad_s: rng.random_range(0.15..0.4),
        },
        BehaviourKind::Biased => {
            let side = if rng.random::<bool>() { 1.0 } else { -1.0 };
            Behaviour::Biased {
                mean_rad_s: side * rng.random_range(0.05..0.15),
                sigma_rad_s: rng.random_range(0.03..0.08),
                max_turn_rate_rad_s: 0.35,
            }
        }
        BehaviourKind::Patterned => Behaviour::Patterned {
            turn_rate_rad_s: rng.random_range(0.15..0.3),
            follow_prob: rng.random_range(0.7..0.9),
        },
        BehaviourKind::Spline => {
            let n = rng.random_range(2..=5);
            let mut wps: Vec<[f64; 3]> = Vec::with_capacity(n);
            while wps.len() < n {
                let p = pick_xy(rng);
                if wps.last().is_none_or(|q| dist(xy(*q), p) > 150.0) {
                    wps.push([p[0], p[1], mission_alt(rng)]);
                }
            }
            Behaviour::Spline(SplineTour::new(wps, speed_mps.max(1.0)).expect("distinct waypoints"))
        }
    };
    let p = pick_xy(rng);
    let (contain_center_m, contain_radius_m) = containment(mission);
    let start = TurningStart {
        p_m: [p[0], p[1], mission_alt(rng)],
        heading_rad: rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
        speed_mps,
        contain_center_m,
        contain_radius_m,
    };
    let track = trajectory(&behaviour, &start, duration_s, TRUTH_DT_S, rng);
    MovingSphere {
        radius_m,
        speed_mps,
        behaviour,
        track,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_scenarios_respect_the_rules() {
        for seed in 0..40 {
            let s = generate(Family::Mixed, seed, &ScenarioParams::default());
            assert!(s.mission.cylinders.len() <= 10 && s.spheres.len() <= 10);
            for c in &s.mission.cylinders {
                assert!(c.radius_m >= RADIUS_RANGE_M.0 && c.radius_m <= RADIUS_RANGE_M.1);
                assert!(c.top_m >= CYL_TOP_RANGE_M.0 && c.top_m <= CYL_TOP_RANGE_M.1);
                for w in &s.mission.waypoints {
                    assert!(
                        dist(w.p_m, c.center_m) > c.radius_m,
                        "waypoint inside a cylinder"
                    );
                }
            }
            for sp in &s.spheres {
                assert!(sp.radius_m >= RADIUS_RANGE_M.0 && sp.radius_m <= RADIUS_RANGE_M.1);
                assert!(sp.speed_mps <= SPEED_RANGE_MPS.1 + 1e-9);
                assert!(sp.track.duration_s() >= s.duration_s - 1e-9);
            }
            for w in &s.mission.waypoints {
                assert!(point_in_polygon(w.p_m, fly_zone(&s.mission)));
            }
        }
    }

    #[test]
    fn the_same_seed_gives_the_same_scenario() {
        let p = ScenarioParams::default();
        assert_eq!(
            generate(Family::Mixed, 7, &p),
            generate(Family::Mixed, 7, &p)
        );
        assert_ne!(
            generate(Family::Mixed, 7, &p),
            generate(Family::Mixed, 8, &p)
        );
    }
}
