//! Helpers of [`super::plan_until`] for its candidate routes: the widened cylinders they
//! are planned against, the tangent-graph completion of a blocked leg, removal of avoid
//! items whose turns cannot be flown, the target of the detour net and the reported risk.

use crate::cost::{LegEnv, PathRisk, better};
use crate::geometry::{Point, dist};
use crate::mission::Zones;
use crate::stack::StackItem;
use crate::turn::sharp_avoid_items;
use crate::verify::{Conflict, Verification};

use super::AircraftState;

/// `cylinders` each widened by `margin_m`, less where that would swallow one of
/// `keep_out` (the aircraft and the fixed items still to fly): such a cylinder is widened
/// only to 1 m short of the nearest of them (never narrowed).
pub(super) fn widen_cylinders(
    cylinders: &[crate::mission::Cylinder],
    keep_out: &[Point],
    margin_m: f64,
) -> Vec<crate::mission::Cylinder> {
    cylinders
        .iter()
        .map(|c| {
            let room = keep_out
                .iter()
                .map(|&q| dist(q, c.center_m) - c.radius_m - 1.0)
                .fold(f64::INFINITY, f64::min);
            crate::mission::Cylinder {
                radius_m: c.radius_m + margin_m.min(room).max(0.0),
                ..*c
            }
        })
        .collect()
}

/// The tangent graph's route from `a` to `b` at `alt_m` around the cylinders inside the
/// fly zone that holds `a` (or the first), `None` when there is none.
pub(super) fn tangent_route(
    a: Point,
    b: Point,
    alt_m: f64,
    cylinders: &[crate::mission::Cylinder],
    zones: &Zones,
) -> Option<Vec<Point>> {
    let g = crate::tangent::TangentGraphParams::default();
    let circles = crate::tangent::inflated_circles(cylinders, alt_m, &g);
    let zone: &[Point] = zones
        .polygons()
        .iter()
        .find(|z| z.contains(a))
        .or(zones.polygons().first())
        .map_or(&[], |z| z.vertices());
    crate::tangent::shortest_path(a, b, &circles, zone, &g)
}

/// The plan's reported risk: 1 with a hard violation, else the verified peak.
pub(super) fn risk_of(v: &Verification) -> f64 {
    if v.hard() > 0 { 1.0 } else { v.peak_risk }
}

/// Index in `tail` of the first fixed item at or after the first conflict of `v` (the end
/// of the leg where it happens), or the first fixed item when the conflict's leg is not
/// known.
pub(super) fn first_fixed_after_conflict(
    tail: &[StackItem],
    v: &Verification,
    s: &AircraftState,
    speed_mps: f64,
) -> Option<usize> {
    let leg = match v.conflict? {
        Conflict::FlyZone { item } | Conflict::Unreachable { item } => item,
        Conflict::Cylinder { p_m, t_s, .. } | Conflict::Risk { p_m, t_s, .. } => {
            // The leg the aircraft is on at t_s (on the polyline's clock), or the leg
            // nearest p_m when the flown path's clock differs.
            let mut t = s.t_s;
            let mut prev = s.p_m;
            let mut found = None;
            for (i, it) in tail.iter().enumerate() {
                let dt = dist(prev, it.p_m) / speed_mps;
                if t_s <= t + dt + 1e-9 {
                    found = Some(i);
                    break;
                }
                t += dt;
                prev = it.p_m;
            }
            found.unwrap_or_else(|| {
                let mut prev = s.p_m;
                let mut best = (f64::INFINITY, 0);
                for (i, it) in tail.iter().enumerate() {
                    let d = crate::geometry::dist_point_segment(p_m, prev, it.p_m);
                    if d < best.0 {
                        best = (d, i);
                    }
                    prev = it.p_m;
                }
                best.1
            })
        }
    };
    (leg..tail.len()).find(|&i| tail[i].is_fixed())
}

/// Risk of flying from the aircraft state through `tail`, each leg at the lower of its
/// ends' altitudes (through a detour, the lowest since the last fixed item,
/// [`StackItem::low_alt_after`]).
pub(super) fn route_risk<'e>(
    env_at: &impl Fn(f64) -> LegEnv<'e>,
    s: &AircraftState,
    tail: &[StackItem],
    step_m: f64,
) -> PathRisk {
    let mut total = PathRisk {
        end_t_s: s.t_s,
        ..PathRisk::default()
    };
    let (mut prev, mut prev_alt, mut t) = (s.p_m, s.alt_m, s.t_s);
    let bands = crate::cost::leg_bands(s.p_m, s.alt_m, tail, env_at(s.alt_m).speed_mps);
    for (it, band) in tail.iter().zip(bands) {
        let env = env_at(prev_alt.min(it.alt_m)).in_band(band);
        let r = env.path_risk(&[prev, it.p_m], t, step_m);
        total.peak = total.peak.max(r.peak);
        total.exposure_m += r.exposure_m;
        total.hard_violations += r.hard_violations;
        total.length_m += r.length_m;
        t = r.end_t_s;
        prev = it.p_m;
        prev_alt = it.low_alt_after(prev_alt);
    }
    total.end_t_s = t;
    total
}

/// Drops avoid items whose turns cannot be flown when dropping them makes the route no
/// worse; the rest are reported by the caller.
pub(super) fn remove_infeasible_turns<'e>(
    env_at: &impl Fn(f64) -> LegEnv<'e>,
    s: &AircraftState,
    tail: &mut Vec<StackItem>,
    turn_radius_m: f64,
    step_m: f64,
) {
    for _ in 0..4 {
        let bad = sharp_avoid_items(s.p_m, tail, turn_radius_m);
        if bad.is_empty() {
            return;
        }
        let current = route_risk(env_at, s, tail, step_m);
        let mut removed = false;
        for &k in bad.iter().rev() {
            let mut trial = tail.clone();
            trial.remove(k);
            let r = route_risk(env_at, s, &trial, step_m);
            if !better(&current, &r)
                && r.hard_violations <= current.hard_violations
                && r.peak <= current.peak + 1e-12
            {
                *tail = trial;
                removed = true;
                break;
            }
        }
        if !removed {
            return;
        }
    }
}
