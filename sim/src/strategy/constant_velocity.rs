//! Constant-velocity prediction baseline: the tangent-graph route around cylinders, plus a
//! detour around discs centred on constant-velocity extrapolations of the moving spheres.
//!
//! Each period: per sphere, a least-squares line fit of x(t) and y(t) over the last
//! `fit_window_s` of telemetry gives position and velocity; the route from the aircraft is
//! timed at its speed and checked every `check_step_s` up to `horizon_s` against the
//! extrapolated spheres (horizontal distance below radius + buffer, and altitude within
//! radius + buffer of the centre). At the first conflict, candidate detour points beside the
//! predicted obstacle position (both sides, several distances) are tried; the one with no
//! conflict (or the latest first conflict) and the least added length wins, with a
//! hysteresis bonus for staying on the side chosen before.

use super::route::{tangent_route, tangent_stack};
use super::{Command, Strategy, View};
use crate::geometry::{P2, add, dist, perp_left, point_in_polygon, scale, sub, unit, xy};
use crate::mission::{ItemKind, Stack, StackItem};
use crate::tangent_graph::{TangentGraphParams, inflated_circles};
use crate::telemetry::ObstacleObservation;

/// A sphere extrapolated at constant velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CvSphere {
    /// Fitted position at `t0_s`.
    pub p_m: [f64; 3],
    /// Fitted horizontal velocity.
    pub v_mps: P2,
    /// Time of the fit's reference.
    pub t0_s: f64,
    /// Radius.
    pub radius_m: f64,
}

impl CvSphere {
    /// Extrapolated horizontal position at `t_s`.
    pub fn at(&self, t_s: f64) -> P2 {
        let dt = t_s - self.t0_s;
        [
            self.p_m[0] + self.v_mps[0] * dt,
            self.p_m[1] + self.v_mps[1] * dt,
        ]
    }
}

/// Least-squares constant-velocity fit over the last `window_s` of a track.
pub fn fit_cv(track: &[ObstacleObservation], window_s: f64) -> Option<CvSphere> {
    let last = track.last()?;
    let start = track.partition_point(|o| o.t_s < last.t_s - window_s);
    let w = &track[start..];
    let n = w.len() as f64;
    let tm = w.iter().map(|o| o.t_s).sum::<f64>() / n;
    let mut m = [0.0; 3];
    for o in w {
        for k in 0..3 {
            m[k] += o.p_m[k] / n;
        }
    }
    let stt: f64 = w.iter().map(|o| (o.t_s - tm).powi(2)).sum();
    let mut v = [0.0; 2];
    if stt > 1e-9 {
        for k in 0..2 {
            v[k] = w
                .iter()
                .map(|o| (o.t_s - tm) * (o.p_m[k] - m[k]))
                .sum::<f64>()
                / stt;
        }
    }
    let dt = last.t_s - tm;
    Some(CvSphere {
        p_m: [m[0] + v[0] * dt, m[1] + v[1] * dt, m[2]],
        v_mps: v,
        t0_s: last.t_s,
        radius_m: last.radius_m,
    })
}

/// Parameters. Defaults: 3 s fit window, 30 s horizon checked every 0.5 s, buffer 15 m +
/// 20% of the radius, detour distances 1, 1.5, 2 and 3 buffered radii.
#[derive(Debug, Clone)]
pub struct ConstantVelocity {
    /// Fit window, seconds.
    pub fit_window_s: f64,
    /// Look-ahead, seconds.
    pub horizon_s: f64,
    /// Check spacing, seconds.
    pub check_step_s: f64,
    /// Buffer in metres added to every radius.
    pub buffer_m: f64,
    /// Buffer as a fraction of the radius.
    pub buffer_fraction: f64,
    /// Cylinder routing.
    pub graph: TangentGraphParams,
    last_side: f64,
}

impl Default for ConstantVelocity {
    fn default() -> Self {
        Self {
            fit_window_s: 3.0,
            horizon_s: 30.0,
            check_step_s: 0.5,
            buffer_m: 15.0,
            buffer_fraction: 0.2,
            graph: TangentGraphParams::default(),
            last_side: 0.0,
        }
    }
}

impl ConstantVelocity {
    fn buffered(&self, s: &CvSphere) -> f64 {
        s.radius_m * (1.0 + self.buffer_fraction) + self.buffer_m
    }

    /// First conflict along `pts` (altitude per point = the altitude of the point it flies
    /// toward) starting at `t0_s`: `(time, sphere index, position)`.
    fn first_conflict(
        &self,
        pts: &[[f64; 3]],
        t0_s: f64,
        speed: f64,
        spheres: &[CvSphere],
    ) -> Option<(f64, usize, P2)> {
        let step_m = speed * self.check_step_s;
        let mut t = t0_s;
        let mut travelled_in_seg = 0.0;
        for w in pts.windows(2) {
            let (a, b) = (xy(w[0]), xy(w[1]));
            let len = dist(a, b);
            let u = unit(sub(b, a));
            let mut s = travelled_in_seg;
            while s <= len {
                let p = add(a, scale(u, s));
                let tt = t + (s - travelled_in_seg) / speed;
                if tt > t0_s + self.horizon_s {
                    return None;
                }
                for (i, sp) in spheres.iter().enumerate() {
                    let r = self.buffered(sp);
                    if (w[1][2] - sp.p_m[2]).abs() < r && dist(p, sp.at(tt)) < r {
                        return Some((tt, i, p));
                    }
                }
                s += step_m;
            }
            t += (len - travelled_in_seg).max(0.0) / speed;
            travelled_in_seg = s - len;
        }
        None
    }
}

impl Strategy for ConstantVelocity {
    fn period_s(&self) -> f64 {
        1.0
    }
    fn decide(&mut self, view: &View<'_>) -> Command {
        let m = view.mission;
        let g = self.graph;
        let route = |a: P2, b: P2, alt: f64| tangent_route(m, &g, a, b, alt);
        let own = xy(view.own.p_m);
        let base = tangent_stack(view, &g);
        let spheres: Vec<CvSphere> = view
            .tracks
            .iter()
            .filter_map(|t| fit_cv(t, self.fit_window_s))
            .collect();
        let speed = view.aircraft.speed_mps;
        let pts = super::route::route_points(&base, view.own.p_m);
        let Some((tc, i, pc)) = self.first_conflict(&pts, view.t_s, speed, &spheres) else {
            self.last_side = 0.0;
            return Command::Replace(base);
        };
        // direction of travel at the conflict: toward the next route point after pc
        let seg = pts
            .windows(2)
            .find(|w| crate::geometry::point_segment_distance(pc, xy(w[0]), xy(w[1])) < 1e-6);
        let dir = seg.map_or([1.0, 0.0], |w| unit(sub(xy(w[1]), xy(w[0]))));
        let centre = spheres[i].at(tc);
        let r = self.buffered(&spheres[i]);
        let Some(first) = base.remaining().first() else {
            return Command::Replace(base);
        };
        let alt = first.alt_m;
        let mut best: Option<(f64, Stack)> = None;
        let base_len =
            crate::geometry::polyline_length(&pts.iter().map(|p| xy(*p)).collect::<Vec<_>>());
        for side in [1.0, -1.0] {
            for k in [1.0, 1.5, 2.0, 3.0] {
                let w = add(centre, scale(perp_left(dir), side * r * k));
                if !point_in_polygon(w, crate::mission::fly_zone(m)) {
                    continue;
                }
                let circles = inflated_circles(&m.cylinders, alt, &g);
                if circles.iter().any(|(c, rc)| dist(*c, w) < *rc) {
                    continue;
                }
                // own -> (route) -> w -> (route) -> rest of the base tail
                let mut items: Vec<StackItem> = base.items[..base.current].to_vec();
                for q in route(own, w, alt) {
                    items.push(StackItem::avoid(q, alt));
                }
                items.push(StackItem::avoid(w, alt));
                let first_mission = base
                    .remaining()
                    .iter()
                    .position(|it| it.kind != ItemKind::Avoid)
                    .unwrap_or(0);
                let tgt = base.remaining()[first_mission];
                for q in route(w, tgt.p_m, alt) {
                    items.push(StackItem::avoid(q, alt));
                }
                items.extend_from_slice(&base.remaining()[first_mission..]);
                let cand = Stack {
                    items,
                    current: base.current,
                };
                let cpts = super::route::route_points(&cand, view.own.p_m);
                let len = crate::geometry::polyline_length(
                    &cpts.iter().map(|p| xy(*p)).collect::<Vec<_>>(),
                );
                let conflict = self.first_conflict(&cpts, view.t_s, speed, &spheres);
                let penalty = match conflict {
                    None => 0.0,
                    Some((t2, _, _)) => 1e6 - (t2 - view.t_s) * 1e3,
                };
                let hyst = if self.last_side != 0.0 && side != self.last_side {
                    100.0
                } else {
                    0.0
                };
                let cost = penalty + (len - base_len) + hyst;
                if best.as_ref().is_none_or(|(c, _)| cost < *c) {
                    best = Some((cost, cand));
                    if conflict.is_none() {
                        self.last_side = side;
                    }
                }
            }
        }
        match best {
            // keep the base when every detour conflicts sooner than it does
            Some((cost, cand)) if cost < 1e6 - (tc - view.t_s) * 1e3 => Command::Replace(cand),
            _ => Command::Replace(base),
        }
    }
}
