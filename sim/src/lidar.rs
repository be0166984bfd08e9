//! A simulated 2-D LiDAR at the aircraft's altitude: beams fanned counter-clockwise from
//! `angle_min` relative to the heading, each returning the distance to the nearest obstacle
//! cross-section (a cylinder when the aircraft is at or below its top; a sphere's circle of
//! radius `sqrt(r^2 - dz^2)` when the altitude cuts it), or infinity beyond the range.
//!
//! # Units
//! Metres, degrees relative to the heading (0 ahead, counter-clockwise positive, as the
//! reactive avoiders expect).

use serde::{Deserialize, Serialize};

use crate::geometry::{P2, ray_circle};

/// Scanner parameters. Defaults: 360 beams over 360 degrees starting straight behind
/// (-180 deg), range 150 m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LidarParams {
    /// Number of beams.
    pub beams: usize,
    /// Field of view, degrees.
    pub fov_deg: f64,
    /// Angle of the first beam relative to the heading, degrees.
    pub angle_min_deg: f64,
    /// Maximum range, metres.
    pub range_m: f64,
}

impl Default for LidarParams {
    fn default() -> Self {
        Self {
            beams: 360,
            fov_deg: 360.0,
            angle_min_deg: -180.0,
            range_m: 150.0,
        }
    }
}

impl LidarParams {
    planner::setters! {
        /// Sets the range.
        range_m(range_m: f64);
        /// Sets the beam count.
        beams(beams: usize);
    }
    /// Angle of beam `i` relative to the heading, degrees.
    pub fn angle_deg(&self, i: usize) -> f64 {
        let step = if (self.fov_deg - 360.0).abs() < 1e-9 {
            self.fov_deg / self.beams as f64
        } else {
            self.fov_deg / (self.beams.max(2) - 1) as f64
        };
        self.angle_min_deg + step * i as f64
    }
}

/// One scan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scan {
    /// Beam angles relative to the heading, degrees.
    pub angles_deg: Vec<f64>,
    /// Ranges, metres (`f64::INFINITY` for no return).
    pub ranges_m: Vec<f64>,
}

/// Scans circles (centre, radius) from `origin_m` with the given heading.
pub fn scan(params: &LidarParams, origin_m: P2, heading_rad: f64, circles: &[(P2, f64)]) -> Scan {
    let mut angles_deg = Vec::with_capacity(params.beams);
    let mut ranges_m = Vec::with_capacity(params.beams);
    // only circles that can be within range
    let near: Vec<(P2, f64)> = circles
        .iter()
        .copied()
        .filter(|(c, r)| crate::geometry::dist(*c, origin_m) - r <= params.range_m)
        .collect();
    for i in 0..params.beams {
        let a = params.angle_deg(i);
        let th = heading_rad + a.to_radians();
        let dir = [th.cos(), th.sin()];
        let mut best = f64::INFINITY;
        for (c, r) in &near {
            if let Some(t) = ray_circle(origin_m, dir, *c, *r)
                && t < best
            {
                best = t;
            }
        }
        angles_deg.push(a);
        ranges_m.push(if best <= params.range_m {
            best
        } else {
            f64::INFINITY
        });
    }
    Scan {
        angles_deg,
        ranges_m,
    }
}

/// The cross-sections at altitude `alt_m` of cylinders `(centre, radius, top)` and spheres
/// `(centre, radius)`.
pub fn cross_sections(
    alt_m: f64,
    cylinders: &[(P2, f64, f64)],
    spheres: &[([f64; 3], f64)],
) -> Vec<(P2, f64)> {
    let mut out = Vec::new();
    for (c, r, top) in cylinders {
        if alt_m <= *top {
            out.push((*c, *r));
        }
    }
    for (c, r) in spheres {
        let dz = alt_m - c[2];
        if dz.abs() < *r {
            out.push(([c[0], c[1]], (r * r - dz * dz).sqrt()));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sphere_cut_above_its_centre_shows_a_smaller_circle_straight_ahead() {
        // sphere r = 50 at (100, 0, 100); aircraft at 130 m: dz = 30, section radius 40,
        // so the beam straight ahead (heading east) returns 100 - 40 = 60 m.
        let secs = cross_sections(130.0, &[], &[([100.0, 0.0, 100.0], 50.0)]);
        assert_eq!(secs.len(), 1);
        assert!((secs[0].1 - 40.0).abs() < 1e-12);
        let p = LidarParams::default();
        let s = scan(&p, [0.0, 0.0], 0.0, &secs);
        let ahead = s.angles_deg.iter().position(|a| a.abs() < 1e-9).unwrap();
        assert!((s.ranges_m[ahead] - 60.0).abs() < 1e-9);
        // straight behind: nothing
        assert!(s.ranges_m[0].is_infinite());
        // a cylinder whose top is below the aircraft is invisible
        assert!(cross_sections(130.0, &[([0.0, 0.0], 10.0, 120.0)], &[]).is_empty());
    }
}
