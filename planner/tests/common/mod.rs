//! Test and bench support: a synthetic moving-obstacle risk field (until the predictor's
//! `RiskMap` is used directly) and a Webster Field mission converted to ENU.
#![allow(dead_code)]

use planner::geometry::{Point, dist, dist_point_segment, lerp, segments_intersect};
use predictor::RiskField;

/// One moving obstacle: risk 1 within `radius_m` of its centre, a Gaussian fall-off
/// outside whose spread grows with the time ahead (prediction uncertainty).
#[derive(Debug, Clone, Copy)]
pub struct Blob {
    /// Centre at t = 0, ENU metres.
    pub p0_m: Point,
    /// Velocity, m/s.
    pub v_mps: Point,
    /// Hard radius, metres.
    pub radius_m: f64,
    /// Fall-off spread at t = 0, metres.
    pub sigma0_m: f64,
    /// Spread growth, metres per second.
    pub growth_mps: f64,
}

impl Blob {
    fn center(&self, t: f64) -> Point {
        [
            self.p0_m[0] + self.v_mps[0] * t,
            self.p0_m[1] + self.v_mps[1] * t,
        ]
    }
    fn sigma(&self, t: f64) -> f64 {
        self.sigma0_m + self.growth_mps * t.max(0.0)
    }
}

/// Moving Gaussian blobs; risk is the largest blob's value.
#[derive(Debug, Clone, Default)]
pub struct Blobs(pub Vec<Blob>);

impl RiskField for Blobs {
    fn risk(&self, p: [f64; 2], t: f64) -> f64 {
        let mut r: f64 = 0.0;
        for b in &self.0 {
            let d = (dist(p, b.center(t)) - b.radius_m).max(0.0);
            let s = b.sigma(t);
            // Cheap reject beyond 4 sigma (risk < 3.4e-4).
            if d > 4.0 * s {
                continue;
            }
            r = r.max((-d * d / (2.0 * s * s)).exp());
        }
        r
    }

    fn segment_risk_bound(&self, a: [f64; 2], b: [f64; 2], t0: f64, t1: f64) -> f64 {
        // Conservative: distance between the leg and the segment swept by the centre.
        let mut r: f64 = 0.0;
        for o in &self.0 {
            let (c0, c1) = (o.center(t0), o.center(t1));
            let d = if segments_intersect(a, b, c0, c1) {
                0.0
            } else {
                dist_point_segment(c0, a, b)
                    .min(dist_point_segment(c1, a, b))
                    .min(dist_point_segment(a, c0, c1))
                    .min(dist_point_segment(b, c0, c1))
            };
            let d = (d - o.radius_m).max(0.0);
            let s = o.sigma(t0).max(o.sigma(t1));
            if d > 4.0 * s {
                continue;
            }
            r = r.max((-d * d / (2.0 * s * s)).exp());
        }
        r
    }
}

/// Densely sampled check that `segment_risk_bound` is an upper bound (used in tests).
pub fn sampled_max(f: &dyn RiskField, a: Point, b: Point, t0: f64, t1: f64) -> f64 {
    (0..=200)
        .map(|i| {
            let u = f64::from(i) / 200.0;
            f.risk(lerp(a, b, u), t0 + (t1 - t0) * u)
        })
        .fold(0.0, f64::max)
}

/// The 2021 Webster Field interop mission in ENU metres (origin: the lost-comms position,
/// altitude 0 MSL), read and converted by the `wire` crate (WGS84 -> ECEF -> ENU).
pub fn webster() -> planner::Mission {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/fixtures/interop/mission_2021_webster_field.json"
    );
    let text = std::fs::read_to_string(path).expect("Webster fixture");
    wire::domain::read_mission_text(&text, "webster")
        .expect("the Webster fixture is a valid mission")
        .to_planner()
}

/// `n` synthetic moving obstacles over the mission's bounding box, from a seed.
pub fn synthetic_movers(mission: &planner::Mission, n: usize, seed: u64) -> Blobs {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let pts = &mission.fly_zones[0].boundary_m;
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in pts {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    Blobs(
        (0..n)
            .map(|_| {
                let heading: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                let speed: f64 = rng.random_range(0.0..20.0);
                Blob {
                    p0_m: [
                        rng.random_range(lo[0]..hi[0]),
                        rng.random_range(lo[1]..hi[1]),
                    ],
                    v_mps: [speed * heading.sin(), speed * heading.cos()],
                    radius_m: rng.random_range(10.0..45.0),
                    sigma0_m: 10.0,
                    growth_mps: 1.0,
                }
            })
            .collect(),
    )
}

/// `n` cylinders placed between the mission's consecutive waypoints (so they matter),
/// deterministically, for static-only benches.
pub fn cylinders_on_legs(
    mission: &planner::Mission,
    n: usize,
    seed: u64,
) -> Vec<planner::Cylinder> {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let zone = planner::mission::Zones::new(&mission.fly_zones);
    let w = &mission.waypoints;
    let mut out: Vec<planner::Cylinder> = Vec::new();
    let mut tries = 0;
    while out.len() < n && tries < 10_000 {
        tries += 1;
        let i = rng.random_range(0..w.len() - 1);
        let (a, b) = (w[i].p_m, w[i + 1].p_m);
        let c = lerp(a, b, rng.random_range(0.3..0.7));
        let c = [
            c[0] + rng.random_range(-15.0..15.0),
            c[1] + rng.random_range(-15.0..15.0),
        ];
        let r = rng.random_range(15.0..60.0);
        let clear_of_wps = w.iter().all(|q| dist(q.p_m, c) > 1.3 * r + 20.0);
        let apart = out
            .iter()
            .all(|o| dist(o.center_m, c) > 1.5 * (o.radius_m + r) + 30.0);
        if clear_of_wps
            && apart
            && zone.polygons()[0].boundary_distance(c) > 2.0 * r
            && zone.contains(c)
        {
            out.push(planner::Cylinder {
                center_m: c,
                radius_m: r,
                top_m: 1000.0,
            });
        }
    }
    out
}

/// A replan of `stack` toward its item 1 from `state`: the bisection, an aircraft at 20 m/s
/// with a 40 m turn radius, nothing pending, captured or to revisit.
pub fn replan_request<'a>(
    mission: &'a planner::Mission,
    stack: &'a [planner::StackItem],
    state: planner::AircraftState,
    seed: u64,
) -> planner::Replan<'a> {
    planner::Replan {
        mission,
        aircraft: planner::Aircraft {
            speed_mps: 20.0,
            turn_radius_m: 40.0,
        },
        state,
        stack,
        current_index: 1,
        strategy: planner::Strategy::Bisection,
        seed,
        target_pending_s: None,
        revisit: false,
        captured: false,
    }
}

/// The aircraft at the mission's first waypoint, at its altitude, heading north at 20 m/s at
/// t = 0 (the benches' starting state).
pub fn state_at_first_waypoint(mission: &planner::Mission) -> planner::AircraftState {
    planner::AircraftState {
        p_m: mission.waypoints[0].p_m,
        alt_m: mission.waypoints[0].alt_m,
        heading_rad: 0.0,
        speed_mps: 20.0,
        t_s: 0.0,
    }
}

/// A 2 km leg east from the origin at 100 m MSL inside the rectangle `lo..hi` (altitudes
/// 0-500 m), no cylinder.
pub fn one_leg_mission(lo: Point, hi: Point) -> planner::Mission {
    planner::Mission {
        fly_zones: vec![rect_zone(lo, hi)],
        cylinders: vec![],
        waypoints: waypoints_at_100m(&[[0.0, 0.0], [2000.0, 0.0]]),
    }
}

/// A mission without fly zone (unbounded): `cylinders`, and waypoints at 100 m MSL through
/// `points`.
pub fn open_mission(cylinders: Vec<planner::Cylinder>, points: &[Point]) -> planner::Mission {
    planner::Mission {
        fly_zones: vec![],
        cylinders,
        waypoints: waypoints_at_100m(points),
    }
}

/// Mission waypoints at 100 m MSL through `points`, in order.
pub fn waypoints_at_100m(points: &[Point]) -> Vec<planner::Waypoint> {
    points
        .iter()
        .map(|&p_m| planner::Waypoint { p_m, alt_m: 100.0 })
        .collect()
}

/// A cylinder 200 m tall (above legs at 100 m MSL).
pub fn cylinder(center_m: Point, radius_m: f64) -> planner::Cylinder {
    planner::Cylinder {
        center_m,
        radius_m,
        top_m: 200.0,
    }
}

/// The rectangle `lo..hi` as a fly zone with altitudes 0-500 m MSL.
pub fn rect_zone(lo: Point, hi: Point) -> planner::FlyZone {
    planner::FlyZone {
        boundary_m: vec![
            [lo[0], lo[1]],
            [hi[0], lo[1]],
            [hi[0], hi[1]],
            [lo[0], hi[1]],
        ],
        alt_min_m: 0.0,
        alt_max_m: 500.0,
    }
}

/// Replans on a prebuilt risk map with the obstacle summaries of the predictor it was built
/// from (the server's side of the seam), without a deadline.
pub fn replan_on_map(
    r: &planner::Replan<'_>,
    map: &predictor::RiskMap,
    p: &predictor::Predictor,
    cfg: &planner::ReplanConfig,
) -> planner::Replanned {
    let summaries: Vec<_> = p.obstacles().collect();
    let dynamic = planner::Dynamic::Map {
        map,
        obstacles: &summaries,
    };
    planner::replan(r, dynamic, cfg, &planner::Termination::none()).unwrap()
}
