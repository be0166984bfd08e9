//! Search-area ladder (lawnmower) pattern (seed 002, "Pathfinding algorithm": the feasible
//! path pre-processing "a simple ladder pattern for searching the computer vision area";
//! DESIGN.md "Planner").
//!
//! Parallel sweep lines at `spacing_m` cover the search polygon (the interop
//! `search_grid_points`, in ENU metres), running along `heading_rad` (compass, 0 = north).
//! Each line spans the polygon between its first and last boundary crossing, shortened by
//! `margin_m` at both ends (for a non-convex polygon a line may cross an outside notch).
//!
//! Turn feasibility: a fixed wing joins two consecutive lines with a U-turn whose diameter
//! is their separation, so the separation must be at least `2 R`. With
//! `spacing_m >= 2 R` the lines are flown in order, alternating direction (boustrophedon).
//! With a tighter spacing they are flown in a skip order: from each line, the next is the
//! nearest unvisited line at least `k = ceil(2 R / spacing)` lines away, so every U-turn
//! spans at least `2 R` (several passes interleave, like a racetrack); only when no such
//! line is left (the last few) does it take the nearest line, and that turn is counted in
//! [`Ladder::tight_turns`].
//!
//! # Example
//! ```
//! use planner::ladder::{ladder, LadderParams};
//! let square = [[0.0, 0.0], [300.0, 0.0], [300.0, 300.0], [0.0, 300.0]];
//! let l = ladder(&square, &LadderParams::default().spacing_m(100.0)).unwrap();
//! assert_eq!(l.lines, 3);
//! assert_eq!(l.points.len(), 6);
//! assert_eq!(l.tight_turns, 0);
//! ```

use crate::geometry::{Point, add, dot, lerp, perp, scale};

/// How lines are ordered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum LadderOrder {
    /// Boustrophedon when `spacing >= 2 R`, else skip order (default).
    #[default]
    Auto,
    /// Lines in order, alternating direction.
    Boustrophedon,
    /// Skip order (see the module docs).
    Skip,
}

/// Ladder parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LadderParams {
    /// Distance between sweep lines, metres (camera footprint). Default 60.
    pub spacing_m: f64,
    /// Direction of the sweep lines, compass radians (0 = north). Default 0.
    pub heading_rad: f64,
    /// Shortening at both ends of each line, metres. Default 0.
    pub margin_m: f64,
    /// Aircraft turn radius, metres. Default 40.
    pub turn_radius_m: f64,
    /// Line order. Default [`LadderOrder::Auto`].
    pub order: LadderOrder,
}

impl Default for LadderParams {
    fn default() -> Self {
        Self {
            spacing_m: 60.0,
            heading_rad: 0.0,
            margin_m: 0.0,
            turn_radius_m: 40.0,
            order: LadderOrder::Auto,
        }
    }
}

impl LadderParams {
    setters! {
        /// Sets the spacing, metres.
        spacing_m(spacing_m: f64);
        /// Sets the sweep direction, compass radians.
        heading_rad(heading_rad: f64);
        /// Sets the turn radius, metres.
        turn_radius_m(turn_radius_m: f64);
        /// Sets the end margin, metres.
        margin_m(margin_m: f64);
        /// Sets the order.
        order(order: LadderOrder);
    }
}

/// A ladder pattern.
#[derive(Debug, Clone, PartialEq)]
pub struct Ladder {
    /// Waypoints in flight order (two per line).
    pub points: Vec<Point>,
    /// Number of sweep lines.
    pub lines: usize,
    /// The order used (never `Auto`).
    pub order: LadderOrder,
    /// Transitions between lines closer than `2 R`.
    pub tight_turns: usize,
}

/// Bad input to [`ladder`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LadderError {
    /// The polygon has fewer than 3 vertices: send the search area's boundary.
    #[error("search polygon needs at least 3 vertices")]
    TooFewVertices,
    /// Spacing not positive and finite: send the camera footprint width.
    #[error("spacing must be positive, got {0}")]
    BadSpacing(f64),
}

/// Builds the ladder over `polygon` (ENU metres).
///
/// # Errors
/// [`LadderError`] for a degenerate polygon or a non-positive spacing.
pub fn ladder(polygon: &[Point], params: &LadderParams) -> Result<Ladder, LadderError> {
    if polygon.len() < 3 {
        return Err(LadderError::TooFewVertices);
    }
    if !(params.spacing_m > 0.0 && params.spacing_m.is_finite()) {
        return Err(LadderError::BadSpacing(params.spacing_m));
    }
    let d = [params.heading_rad.sin(), params.heading_rad.cos()];
    let n = perp(d);
    let (lo, hi) = polygon
        .iter()
        .map(|&p| dot(p, n))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let mut segs: Vec<(Point, Point)> = Vec::new();
    let mut o = lo + params.spacing_m / 2.0;
    // A polygon narrower than one spacing still gets its centre line.
    if o > hi {
        o = 0.5 * (lo + hi);
    }
    while o <= hi + 1e-9 {
        let mut smin = f64::INFINITY;
        let mut smax = f64::NEG_INFINITY;
        for i in 0..polygon.len() {
            let p = polygon[i];
            let q = polygon[(i + 1) % polygon.len()];
            let (pn, qn) = (dot(p, n), dot(q, n));
            if (pn > o) != (qn > o) {
                let x = lerp(p, q, (o - pn) / (qn - pn));
                let s = dot(x, d);
                smin = smin.min(s);
                smax = smax.max(s);
            }
        }
        smin += params.margin_m;
        smax -= params.margin_m;
        if smax > smin {
            let base = scale(n, o);
            segs.push((add(base, scale(d, smin)), add(base, scale(d, smax))));
        }
        o += params.spacing_m;
    }
    let two_r = 2.0 * params.turn_radius_m;
    let order = match params.order {
        LadderOrder::Auto if params.spacing_m + 1e-9 >= two_r => LadderOrder::Boustrophedon,
        LadderOrder::Auto => LadderOrder::Skip,
        o => o,
    };
    let m = segs.len();
    let sequence: Vec<usize> = match order {
        LadderOrder::Skip => {
            let k = ((two_r / params.spacing_m) - 1e-9).ceil().max(1.0) as usize;
            let mut visited = vec![false; m];
            let mut seq = Vec::with_capacity(m);
            let mut cur = 0usize;
            for step in 0..m {
                if step > 0 {
                    let pick = (0..m)
                        .filter(|&j| !visited[j] && j.abs_diff(cur) >= k)
                        .min_by_key(|&j| (j.abs_diff(cur), usize::MAX - j))
                        .or_else(|| {
                            (0..m)
                                .filter(|&j| !visited[j])
                                .min_by_key(|&j| j.abs_diff(cur))
                        });
                    let Some(j) = pick else { break };
                    cur = j;
                }
                visited[cur] = true;
                seq.push(cur);
            }
            seq
        }
        _ => (0..m).collect(),
    };
    let mut points = Vec::with_capacity(2 * m);
    let mut tight_turns = 0;
    for (step, &j) in sequence.iter().enumerate() {
        let (a, b) = segs[j];
        if step % 2 == 0 {
            points.extend([a, b]);
        } else {
            points.extend([b, a]);
        }
        if step > 0 && (sequence[step - 1].abs_diff(j) as f64) * params.spacing_m + 1e-9 < two_r {
            tight_turns += 1;
        }
    }
    Ok(Ladder {
        points,
        lines: m,
        order,
        tight_turns,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tight_spacing_uses_a_skip_order_with_wide_turns() {
        // 600 m square, spacing 30 m -> 20 lines at x = 15, 45, ..., 585 (heading north,
        // lines run along y; the normal is west, so offsets are -x). R = 40 -> 2R = 80,
        // k = ceil(80/30) = 3 lines apart.
        let sq = [[0.0, 0.0], [600.0, 0.0], [600.0, 600.0], [0.0, 600.0]];
        let l = ladder(
            &sq,
            &LadderParams::default().spacing_m(30.0).turn_radius_m(40.0),
        )
        .unwrap();
        assert_eq!(l.lines, 20);
        assert_eq!(l.order, LadderOrder::Skip);
        assert_eq!(l.points.len(), 40);
        assert!(l.tight_turns <= 2, "{}", l.tight_turns);
        // Every line is flown once.
        let mut xs: Vec<i64> = l.points.iter().map(|p| p[0].round() as i64).collect();
        xs.sort_unstable();
        xs.dedup();
        assert_eq!(xs.len(), 20);
    }

    #[test]
    fn wide_spacing_is_a_plain_lawnmower() {
        let sq = [[0.0, 0.0], [400.0, 0.0], [400.0, 400.0], [0.0, 400.0]];
        let l = ladder(&sq, &LadderParams::default().spacing_m(100.0)).unwrap();
        assert_eq!(l.order, LadderOrder::Boustrophedon);
        assert_eq!(l.lines, 4);
        // Alternating directions: the second line starts where the first ended (same y).
        assert!((l.points[1][1] - l.points[2][1]).abs() < 1e-9);
    }
}
