//! Reactive LiDAR strategies, onboard style, on top of the tangent-graph route around the
//! cylinders (planned at the first call by [`super::tangent`]; these decide the calls after
//! it, through [`super::FirstThen`]):
//!
//! - [`Offset`]: the planner's Offset Algorithm (seeds 000/001) on the simulated LiDAR at
//!   10 Hz, scaled to an aircraft (scan radii 30-150 m, window 16 one-degree beams, field of
//!   view 120 degrees). When the way ahead is blocked and a side is found, the BlackFly pilot
//!   (seed 001) plans the quadratic Bezier out to the deviation and back to the goal line
//!   (in the sensor frame: forward along the heading; maximum deviation 150 m); the
//!   away segment's mid-point and its end `P` are inserted before the target as avoid
//!   waypoints (the aircraft's L1 guidance then flies back to the goal line by itself). A new
//!   avoidance is planned at most once per second, every 3 s while one is being flown; the
//!   items of the previous one still ahead are dropped first.
//! - [`Sectors`]: the planner's 8-region sector avoider (seed 003) on the same LiDAR with an
//!   obstacle threshold of 100 m. While the front region is blocked the aircraft turns at
//!   its maximum rate toward the chosen region (the seed's `sign(cost) * 0.7` becomes
//!   `sign(cost) * omega_max`; the seed's reverse speed has no fixed-wing equivalent and is
//!   ignored); otherwise it follows the stack.

use planner::reactive::{
    Beam, OffsetParams, OffsetWorkspace, PilotInput, PilotParams, SectorParams, pilot_plan,
    sectors_decide,
};

use super::{Command, Strategy, View};
use crate::geometry::{P2, add, dist, perp_left, scale, xy};
use crate::lidar::{LidarParams, Scan};
use crate::mission::{ItemKind, Stack, StackItem};

/// An onboard avoider: decides from each LiDAR scan.
pub trait Avoider: Send {
    /// The command for this scan.
    fn react(&mut self, view: &View<'_>, scan: &Scan) -> Command;
}

/// An [`Avoider`] on the simulated LiDAR, deciding at the scanner's 10 Hz (no scan: keep).
#[derive(Debug)]
pub struct Onboard<A> {
    /// The avoider.
    pub avoider: A,
    /// Scanner.
    pub lidar: LidarParams,
}

impl<A> Onboard<A> {
    /// `avoider` on the default scanner.
    pub fn new(avoider: A) -> Self {
        Self {
            avoider,
            lidar: LidarParams::default(),
        }
    }
}

impl<A: Avoider> Strategy for Onboard<A> {
    fn period_s(&self) -> f64 {
        0.1
    }
    fn lidar(&self) -> Option<LidarParams> {
        Some(self.lidar)
    }
    fn decide(&mut self, view: &View<'_>) -> Command {
        match view.scan {
            Some(scan) => self.avoider.react(view, scan),
            None => Command::Keep,
        }
    }
}

/// Offset algorithm + Bezier pilot.
#[derive(Debug)]
pub struct Offset {
    /// Offset parameters.
    pub offset: OffsetParams,
    /// Pilot parameters.
    pub pilot: PilotParams,
    ws: OffsetWorkspace,
    last_avoid_s: f64,
    beams: Vec<Beam>,
    inserted: Vec<P2>,
}

impl Default for Offset {
    fn default() -> Self {
        Self {
            offset: OffsetParams::default()
                .with_scan_radii_m(vec![30.0, 60.0, 90.0, 120.0, 150.0])
                .with_window(16)
                .with_fov_deg(120.0),
            pilot: PilotParams::default().with_max_deviation_m(150.0),
            ws: OffsetWorkspace::new(),
            last_avoid_s: f64::NEG_INFINITY,
            beams: Vec::new(),
            inserted: Vec::new(),
        }
    }
}

impl Avoider for Offset {
    fn react(&mut self, view: &View<'_>, scan: &Scan) -> Command {
        let Some(target) = view.stack.target() else {
            return Command::Keep;
        };
        // one avoidance at a time: while flying toward an inserted point, re-plan only every 3 s
        let avoiding = target.kind == ItemKind::Avoid && self.inserted.contains(&target.p_m);
        if view.t_s - self.last_avoid_s < if avoiding { 3.0 } else { 1.0 } {
            return Command::Keep;
        }
        self.beams.clear();
        self.beams.extend(
            scan.angles_deg
                .iter()
                .zip(&scan.ranges_m)
                .map(|(a, d)| Beam::new(*a, *d)),
        );
        let Ok(dec) = self.ws.decide(&self.beams, &self.offset) else {
            return Command::Keep;
        };
        if dec.way_ahead_clear || dec.direction.is_none() {
            return Command::Keep;
        }
        let own = xy(view.own.p_m);
        let goal = target.p_m;
        let lookahead = self.offset.lookahead_m.unwrap_or(150.0);
        let goal_distance = dist(own, goal).max(lookahead + 1.0);
        let Ok(plan) = pilot_plan(
            &PilotInput::new(dec.deviation_m, lookahead, goal_distance),
            &self.pilot,
        ) else {
            return Command::Keep;
        };
        self.last_avoid_s = view.t_s;
        // sensor frame: y along the heading (the scan's 0 degrees), x to its left
        let u = [view.own.heading_rad.cos(), view.own.heading_rad.sin()];
        let to_world = |x: f64, y: f64| add(add(own, scale(u, y)), scale(perp_left(u), x));
        let pts = plan.sample(2);
        // drop previous reactive items at the head of the remaining stack
        let mut items: Vec<StackItem> = view.stack.items[..view.stack.current].to_vec();
        let rest = view.stack.remaining();
        let skip = rest
            .iter()
            .take_while(|it| it.kind == ItemKind::Avoid && self.inserted.contains(&it.p_m))
            .count();
        let alt = target.alt_m;
        self.inserted.clear();
        for p in pts.iter().skip(1).take(2) {
            let w = to_world(p.x_m, p.y_m);
            self.inserted.push(w);
            items.push(StackItem::avoid(w, alt));
        }
        items.extend_from_slice(&rest[skip..]);
        Command::Replace(Stack {
            items,
            current: view.stack.current,
        })
    }
}

/// Sector avoider.
#[derive(Debug)]
pub struct Sectors {
    /// Sector parameters.
    pub sectors: SectorParams,
}

impl Default for Sectors {
    fn default() -> Self {
        Self {
            sectors: SectorParams::default().with_obj_threshold_m(100.0),
        }
    }
}

impl Avoider for Sectors {
    fn react(&mut self, view: &View<'_>, scan: &Scan) -> Command {
        let angle_min = scan.angles_deg.first().copied().unwrap_or(0.0);
        let Ok(d) = sectors_decide(&scan.ranges_m, angle_min, &self.sectors) else {
            return Command::Keep;
        };
        if !d.obstacle_detected || d.angular_velocity == 0.0 {
            return Command::Keep;
        }
        let w = view.aircraft.max_turn_rate_rad_s();
        Command::Steer {
            turn_rate_rad_s: w.copysign(d.angular_velocity),
            hold_s: 0.15,
        }
    }
}
