//! Shortest path around cylinders on a tangent graph (no seed; the strongest static-only
//! approach SUAS teams used). The planner falls back on it when the seed 004 pre-pass leaves
//! a leg crossing a cylinder, so that with cylinders alone a clear route is found whenever
//! one exists at the polygon's resolution (issue 10, "complete around cylinders"); the
//! simulator's `tangent` strategy is this alone.
//!
//! Each cylinder that matters at the leg's altitude is inflated (by default by 20% of its
//! radius plus 10 m) and replaced by its circumscribed regular polygon; the polygon's edges
//! are tangent to the inflated circle, so its vertices are tangent points and the graph
//! approaches the exact tangent graph as the number of sides grows. Nodes: the start, the
//! goal and every vertex inside the fly zone and outside every other inflated circle. An edge
//! joins two nodes when the segment clears every inflated circle and stays inside the fly zone.
//! A* with the straight-line heuristic (edges evaluated lazily on expansion) gives the
//! shortest path.
//!
//! # Units
//! ENU metres.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::geometry::{Point as P2, Polygon, dist, dist_point_segment as point_segment_distance};
use crate::mission::Cylinder;

/// Parameters. Defaults: 16 sides, inflation 20% of the radius plus 10 m.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TangentGraphParams {
    /// Sides of the circumscribed polygons.
    pub sides: usize,
    /// Inflation as a fraction of the radius.
    pub margin_fraction: f64,
    /// Inflation added in metres.
    pub margin_m: f64,
}

impl Default for TangentGraphParams {
    fn default() -> Self {
        Self {
            sides: 16,
            margin_fraction: 0.2,
            margin_m: 10.0,
        }
    }
}

impl TangentGraphParams {
    /// Inflated radius of a cylinder.
    pub fn inflated_m(&self, radius_m: f64) -> f64 {
        radius_m * (1.0 + self.margin_fraction) + self.margin_m
    }
}

/// The inflated circles of the cylinders that matter at `alt_m`.
pub fn inflated_circles(
    cylinders: &[Cylinder],
    alt_m: f64,
    params: &TangentGraphParams,
) -> Vec<(P2, f64)> {
    cylinders
        .iter()
        .filter(|c| alt_m <= c.top_m + params.margin_m)
        .map(|c| (c.center_m, params.inflated_m(c.radius_m)))
        .collect()
}

/// Whether the segment clears every circle (touching allowed).
pub fn segment_clear(a: P2, b: P2, circles: &[(P2, f64)]) -> bool {
    circles
        .iter()
        .all(|(c, r)| point_segment_distance(*c, a, b) >= r - 1e-6)
}

#[derive(PartialEq)]
struct Entry {
    f: f64,
    node: usize,
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        o.f.total_cmp(&self.f).then(o.node.cmp(&self.node))
    }
}

/// Shortest path from `from` to `to` around `circles` inside `zone` (an empty zone means
/// unbounded). Returns the intermediate points (empty when the straight segment is clear),
/// or `None` when no path exists. Circles containing `from` or `to` are ignored (the aircraft
/// is already inside the margin; the best it can do is leave).
pub fn shortest_path(
    from: P2,
    to: P2,
    circles: &[(P2, f64)],
    zone: &[P2],
    params: &TangentGraphParams,
) -> Option<Vec<P2>> {
    let circles: Vec<(P2, f64)> = circles
        .iter()
        .copied()
        .filter(|(c, r)| dist(*c, from) > *r && dist(*c, to) > *r)
        .collect();
    let poly = (zone.len() >= 3).then(|| Polygon::new(zone));
    let in_zone = |p: P2| poly.as_ref().is_none_or(|z| z.contains(p));
    let zone_ok = |a: P2, b: P2| {
        poly.as_ref()
            .is_none_or(|z| z.contains_segment(a, b) || !z.contains(a))
    };
    if segment_clear(from, to, &circles) && zone_ok(from, to) {
        return Some(vec![]);
    }
    let n = params.sides.max(3);
    let k = 1.0 / (std::f64::consts::PI / n as f64).cos();
    let mut nodes = vec![from, to];
    for (ci, (c, r)) in circles.iter().enumerate() {
        for s in 0..n {
            let a = std::f64::consts::TAU * s as f64 / n as f64;
            let v = [c[0] + r * k * a.cos(), c[1] + r * k * a.sin()];
            let free = circles
                .iter()
                .enumerate()
                .all(|(j, (cj, rj))| j == ci || dist(*cj, v) >= *rj);
            if free && in_zone(v) {
                nodes.push(v);
            }
        }
    }
    let m = nodes.len();
    let mut g = vec![f64::INFINITY; m];
    let mut parent = vec![usize::MAX; m];
    let mut closed = vec![false; m];
    let mut heap = BinaryHeap::new();
    g[0] = 0.0;
    heap.push(Entry {
        f: dist(from, to),
        node: 0,
    });
    while let Some(Entry { node, .. }) = heap.pop() {
        if closed[node] {
            continue;
        }
        closed[node] = true;
        if node == 1 {
            let mut path = vec![];
            let mut cur = parent[1];
            while cur != 0 {
                path.push(nodes[cur]);
                cur = parent[cur];
            }
            path.reverse();
            return Some(path);
        }
        let a = nodes[node];
        for j in 1..m {
            if closed[j] {
                continue;
            }
            let b = nodes[j];
            let ng = g[node] + dist(a, b);
            if ng >= g[j] {
                continue;
            }
            if segment_clear(a, b, &circles) && zone_ok(a, b) {
                g[j] = ng;
                parent[j] = node;
                heap.push(Entry {
                    f: ng + dist(b, to),
                    node: j,
                });
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fly zone x in [-10, 1010], y in [y_min, y_max]: a strip along the test legs.
    fn strip(y_min: f64, y_max: f64) -> [P2; 4] {
        [
            [-10.0, y_min],
            [1010.0, y_min],
            [1010.0, y_max],
            [-10.0, y_max],
        ]
    }

    #[test]
    fn a_clear_leg_needs_no_detour() {
        let p = TangentGraphParams::default();
        assert_eq!(
            shortest_path([0.0, 0.0], [100.0, 0.0], &[([50.0, 50.0], 10.0)], &[], &p),
            Some(vec![])
        );
    }

    #[test]
    fn a_circle_on_the_leg_is_rounded_close_to_the_exact_tangent_path() {
        // Circle r = 50 at (500, 0), leg (0,0) -> (1000, 0). The exact shortest path: tangent
        // segments of length sqrt(500^2 - 50^2) = 497.49 each and the arc between the tangent
        // points, angle 2 * asin(50/500) = 0.20034 rad, length 10.02: total 1005.0 m.
        let p = TangentGraphParams {
            sides: 64,
            ..Default::default()
        };
        let path =
            shortest_path([0.0, 0.0], [1000.0, 0.0], &[([500.0, 0.0], 50.0)], &[], &p).unwrap();
        assert!(!path.is_empty());
        let mut pts = vec![[0.0, 0.0]];
        pts.extend(path);
        pts.push([1000.0, 0.0]);
        let len = crate::geometry::polyline_length(&pts);
        assert!((1005.0 - 1e-6..1005.5).contains(&len), "{len}");
        assert!(
            pts.windows(2)
                .all(|w| segment_clear(w[0], w[1], &[([500.0, 0.0], 50.0 - 1e-3)]))
        );
    }

    #[test]
    fn the_fly_zone_forces_the_other_side() {
        // Zone is a strip y in [-100, 20]: the north side of the circle (y up to ~52) is
        // outside, so the path must go south.
        let zone = strip(-100.0, 20.0);
        let p = TangentGraphParams::default();
        let path = shortest_path(
            [0.0, 0.0],
            [1000.0, 0.0],
            &[([500.0, 0.0], 50.0)],
            &zone,
            &p,
        )
        .unwrap();
        assert!(path.iter().all(|q| q[1] < 0.0), "{path:?}");
    }

    #[test]
    fn a_wall_of_circles_across_the_zone_leaves_no_path() {
        // Strip y in [-100, 100]; circles every 60 m across it with r = 40 overlap: blocked.
        let zone = strip(-100.0, 100.0);
        let wall: Vec<(P2, f64)> = (-2..=2)
            .map(|i| ([500.0, 60.0 * f64::from(i)], 40.0))
            .collect();
        let p = TangentGraphParams::default();
        assert_eq!(
            shortest_path([0.0, 0.0], [1000.0, 0.0], &wall, &zone, &p),
            None
        );
    }
}
