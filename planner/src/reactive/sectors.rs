//! The sector avoider (seed 003 "Obstacle Avoidance using LIDAR"): split the 360 degrees
//! around the vehicle into 8 regions, and when the front is blocked turn toward the
//! obstacle-free region closest to the front.
//!
//! # Regions
//!
//! Bearings are degrees, 0 straight ahead, counter-clockwise positive. Region 0 (front) is
//! `[-30, 30)` (`front_width_deg` = 60). Regions `k = 1..=7` are `sector_width_deg` = 45
//! degrees wide and centred on `k * 45` degrees: 1 front-left (45), 2 left (90),
//! 3 back-left (135), 4 back (180), 5 back-right (225), 6 right (270), 7 front-right (315).
//! Their costs are the seed's `0, 1, 2, 3, 4, -3, -2, -1`: the signed number of 45-degree
//! steps from the front, negative = clockwise. The front is wider than its 45-degree slot,
//! so it overlaps regions 1 and 7 by 7.5 degrees each and a beam there counts in both
//! (the seed's slices overlap the same way).
//!
//! A `LaserScan`-like sweep is `ranges_m[i]` at bearing `angle_min_deg + i * 360 / len`.
//!
//! # Filtering and decision (as the seed)
//!
//! A reading counts as an obstacle in a region only when it is finite, `> range_min_m` and
//! `<= obj_threshold_m`; `inf`, `NaN` and readings at or below `range_min_m` are dropped
//! (a region with only such readings is obstacle-free).
//! Then: the obstacle-free region with the lowest `|cost|` wins (ties: the lower region
//! number, i.e. left before right, as the seed's iteration order); if no region is free,
//! the region whose farthest counted reading is largest wins (ties: the lower number).
//! `obstacle_detected` = the front region is not free. When detected the command is
//! `linear = reverse_linear_velocity` (-0.1) and `angular = sign(cost) * avoid_angular_velocity`
//! (0.7; 0 when the cost is 0); otherwise the cruise command.
//!
//! # Corrections to the seed
//!
//! - Regions 1-7 are sliced as `ranges[int(23/360 n) + int(T/360 n)(k-1) : int(23/360 n) +
//!   int(T/360 n) k]` with `ANGLE_THRESHOLD = T` undefined in the text. 23 is 22.5 rounded,
//!   i.e. 45-degree sectors centred on multiples of 45 degrees, which is what the costs
//!   encode. The separate `int()` truncations drift (for `n = 100`, region 7 ends at beam
//!   6 + 12 * 7 = 90, i.e. 324 degrees, not 337.5) and the slicing assumes `angle_min = 0`.
//!   Here every beam is assigned by its own bearing, for any `len` and `angle_min_deg`.
//!   (Seven contiguous 45-degree sectors after a 60-degree front would need 375 degrees; the
//!   seed's own 22.5-degree offset is the geometry that fits.)
//! - The seed's `avoid_angular_vel = (diff / max(1, |diff|)) * 0.7` is `sign(diff) * 0.7`,
//!   implemented as such; its velocities are parameters here.
//!
//! # Example
//! ```
//! use planner::reactive::{SectorParams, sectors_decide};
//! // 360 beams, 1 degree apart, starting straight ahead; a wall 0.4 m ahead from -20..+20
//! let ranges: Vec<f64> = (0..360)
//!     .map(|i| if i <= 20 || i >= 340 { 0.4 } else { f64::INFINITY })
//!     .collect();
//! let d = sectors_decide(&ranges, 0.0, &SectorParams::default()).unwrap();
//! assert!(d.obstacle_detected);
//! assert_eq!(d.region, 1); // front-left is free and nearest
//! assert_eq!(d.angular_velocity, 0.7);
//! assert_eq!(d.linear_velocity, -0.1);
//! ```

/// Region costs from seed 003: signed 45-degree steps from the front.
pub const REGION_COSTS: [i8; 8] = [0, 1, 2, 3, 4, -3, -2, -1];

/// Sector avoider parameters.
///
/// Defaults: `range_min_m` 0.0, `obj_threshold_m` 1.0, `front_width_deg` 60,
/// `sector_width_deg` 45, `avoid_angular_velocity` 0.7, `reverse_linear_velocity` -0.1,
/// cruise `linear_velocity` 0.5 and `angular_velocity` 0.0 (the seed leaves these two to the
/// user: the command when the front is clear).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct SectorParams {
    /// Readings at or below this are dropped (the sensor's `range_min`), metres.
    pub range_min_m: f64,
    /// Only readings at or below this count as obstacles (`OBJ_THRESHOLD`), metres.
    pub obj_threshold_m: f64,
    /// Width of the front region, degrees.
    pub front_width_deg: f64,
    /// Width of regions 1-7, degrees (centred on multiples of 45).
    pub sector_width_deg: f64,
    /// Magnitude of the avoidance turn rate (rad/s, or the platform's unit).
    pub avoid_angular_velocity: f64,
    /// Linear velocity while avoiding (negative = reverse).
    pub reverse_linear_velocity: f64,
    /// Linear velocity when the front is clear.
    pub cruise_linear_velocity: f64,
    /// Angular velocity when the front is clear.
    pub cruise_angular_velocity: f64,
}

impl Default for SectorParams {
    fn default() -> Self {
        Self {
            range_min_m: 0.0,
            obj_threshold_m: 1.0,
            front_width_deg: 60.0,
            sector_width_deg: 45.0,
            avoid_angular_velocity: 0.7,
            reverse_linear_velocity: -0.1,
            cruise_linear_velocity: 0.5,
            cruise_angular_velocity: 0.0,
        }
    }
}

impl SectorParams {
    setters! {
        /// Set `range_min_m`.
        with_range_min_m(range_min_m: f64);
        /// Set `obj_threshold_m`.
        with_obj_threshold_m(obj_threshold_m: f64);
    }
    /// Set the cruise command (used when the front is clear).
    pub fn with_cruise(mut self, linear: f64, angular: f64) -> Self {
        self.cruise_linear_velocity = linear;
        self.cruise_angular_velocity = angular;
        self
    }

    /// Check the parameters.
    ///
    /// # Errors
    /// [`SectorError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<(), SectorError> {
        let bad =
            |name: &'static str, value: f64| Err(SectorError::InvalidParameter { name, value });
        if !(self.range_min_m.is_finite() && self.range_min_m >= 0.0) {
            return bad("range_min_m", self.range_min_m);
        }
        if !(self.obj_threshold_m.is_finite() && self.obj_threshold_m > self.range_min_m) {
            return bad("obj_threshold_m", self.obj_threshold_m);
        }
        if !(self.front_width_deg > 0.0 && self.front_width_deg <= 360.0) {
            return bad("front_width_deg", self.front_width_deg);
        }
        if !(self.sector_width_deg > 0.0 && self.sector_width_deg <= 360.0) {
            return bad("sector_width_deg", self.sector_width_deg);
        }
        for (name, v) in [
            ("avoid_angular_velocity", self.avoid_angular_velocity),
            ("reverse_linear_velocity", self.reverse_linear_velocity),
            ("cruise_linear_velocity", self.cruise_linear_velocity),
            ("cruise_angular_velocity", self.cruise_angular_velocity),
        ] {
            if !v.is_finite() {
                return bad(name, v);
            }
        }
        Ok(())
    }
}

/// Bad input to the sector avoider.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SectorError {
    /// No ranges: send the sweep.
    #[error("ranges_m is empty")]
    EmptyScan,
    /// `angle_min_deg` is not finite.
    #[error("angle_min_deg is not finite")]
    NonFiniteAngleMin,
    /// A parameter is out of range: fix it.
    #[error("sector parameter {name} = {value} is out of range")]
    InvalidParameter {
        /// Field name.
        name: &'static str,
        /// The bad value.
        value: f64,
    },
}

/// The sector avoider's answer.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SectorDecision {
    /// The front region is not obstacle-free.
    pub obstacle_detected: bool,
    /// The chosen region, 0-7.
    pub region: u8,
    /// Commanded angular velocity (counter-clockwise positive).
    pub angular_velocity: f64,
    /// Commanded linear velocity.
    pub linear_velocity: f64,
    /// Per region: obstacle-free (no counted reading).
    pub free: [bool; 8],
    /// Per region: the nearest counted reading, metres (`INFINITY` when free).
    pub nearest_m: [f64; 8],
    /// Per region: the farthest counted reading, metres (0 when free).
    pub farthest_m: [f64; 8],
}

/// The regions (0-7) a bearing belongs to, as a bit set.
fn regions_of(bearing_deg: f64, params: &SectorParams) -> u8 {
    // bearing in [0, 360) (fast path without fmod for the usual case)
    let a = if (0.0..360.0).contains(&bearing_deg) {
        bearing_deg
    } else {
        bearing_deg.rem_euclid(360.0)
    };
    let mut set = 0u8;
    let half_front = params.front_width_deg / 2.0;
    // front: [-half, half)
    if a < half_front || a >= 360.0 - half_front {
        set |= 1;
    }
    let half = params.sector_width_deg / 2.0;
    for k in 1..8u8 {
        let c = 45.0 * f64::from(k);
        // signed offset from the centre in [-180, 180): a - c is in (-315, 315)
        let mut off = a - c;
        if off >= 180.0 {
            off -= 360.0;
        } else if off < -180.0 {
            off += 360.0;
        }
        if off >= -half && off < half {
            set |= 1 << k;
        }
    }
    set
}

/// Run the sector avoider on one sweep. Pure and allocation-free.
///
/// `ranges_m[i]` is at bearing `angle_min_deg + i * 360 / ranges_m.len()`.
///
/// # Errors
/// [`SectorError`] for an empty sweep, a non-finite `angle_min_deg` or bad parameters.
pub fn sectors_decide(
    ranges_m: &[f64],
    angle_min_deg: f64,
    params: &SectorParams,
) -> Result<SectorDecision, SectorError> {
    params.validate()?;
    if ranges_m.is_empty() {
        return Err(SectorError::EmptyScan);
    }
    if !angle_min_deg.is_finite() {
        return Err(SectorError::NonFiniteAngleMin);
    }
    let step = 360.0 / ranges_m.len() as f64;
    let mut nearest_m = [f64::INFINITY; 8];
    let mut farthest_m = [0.0f64; 8];
    let mut counted = [false; 8];
    for (i, &x) in ranges_m.iter().enumerate() {
        // the seed's filter: finite, > range_min, <= OBJ_THRESHOLD
        if !(x.is_finite() && x > params.range_min_m && x <= params.obj_threshold_m) {
            continue;
        }
        let set = regions_of(angle_min_deg + i as f64 * step, params);
        for k in 0..8 {
            if set & (1 << k) != 0 {
                counted[k] = true;
                nearest_m[k] = nearest_m[k].min(x);
                farthest_m[k] = farthest_m[k].max(x);
            }
        }
    }
    let free = counted.map(|c| !c);

    // nearest free region by |cost|, ties to the lower region number
    let best_free = (0..8)
        .filter(|&k| free[k])
        .min_by_key(|&k| (REGION_COSTS[k].unsigned_abs(), k));
    let region = match best_free {
        Some(k) => k,
        None => {
            // all blocked: farthest reading, ties to the lower region number (strict >)
            let mut best = 4;
            let mut best_d = 0.0;
            for k in 0..8 {
                if farthest_m[k] > best_d {
                    best_d = farthest_m[k];
                    best = k;
                }
            }
            best
        }
    };
    let obstacle_detected = !free[0];
    let cost = f64::from(REGION_COSTS[region]);
    let (linear_velocity, angular_velocity) = if obstacle_detected {
        let sign = if cost == 0.0 { 0.0 } else { cost.signum() };
        (
            params.reverse_linear_velocity,
            sign * params.avoid_angular_velocity,
        )
    } else {
        (
            params.cruise_linear_velocity,
            params.cruise_angular_velocity,
        )
    };
    Ok(SectorDecision {
        obstacle_detected,
        region: region as u8,
        angular_velocity,
        linear_velocity,
        free,
        nearest_m,
        farthest_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const INF: f64 = f64::INFINITY;

    /// 360 beams, beam i at i degrees (angle_min 0), free except where `f` says.
    fn sweep(f: impl Fn(i32) -> f64) -> Vec<f64> {
        (0..360).map(f).collect()
    }

    #[test]
    fn region_geometry() {
        let p = SectorParams::default();
        // front [-30, 30): 0 and 359 and 29.9 are front; 30 is not
        assert_eq!(regions_of(0.0, &p), 1);
        assert_eq!(regions_of(-20.0, &p), 1);
        // -29.9 = 330.1: front and region 7 ([292.5, 337.5)) overlap
        assert_eq!(regions_of(-29.9, &p), 1 | 1 << 7);
        assert_eq!(regions_of(30.0, &p) & 1, 0);
        // 25 deg: front and region 1 ([22.5, 67.5)) overlap
        assert_eq!(regions_of(25.0, &p), 1 | 1 << 1);
        // 90 left = 2, 180 back = 4, 270 (= -90) right = 6, 320 front-right = 7
        assert_eq!(regions_of(90.0, &p), 1 << 2);
        assert_eq!(regions_of(180.0, &p), 1 << 4);
        assert_eq!(regions_of(-90.0, &p), 1 << 6);
        assert_eq!(regions_of(320.0, &p), 1 << 7);
        // every bearing is in at least one region
        for i in 0..3600 {
            assert_ne!(regions_of(f64::from(i) / 10.0, &p), 0);
        }
    }

    #[test]
    fn clear_front_cruises() {
        let d = sectors_decide(&sweep(|_| INF), 0.0, &SectorParams::default()).unwrap();
        assert!(!d.obstacle_detected);
        assert_eq!(d.region, 0);
        assert_eq!((d.linear_velocity, d.angular_velocity), (0.5, 0.0));
        // an obstacle only behind (180 deg) does not matter
        let d = sectors_decide(
            &sweep(|i| if i == 180 { 0.3 } else { INF }),
            0.0,
            &SectorParams::default(),
        )
        .unwrap();
        assert!(!d.obstacle_detected);
        assert!(!d.free[4]);
    }

    #[test]
    fn front_blocked_turns_to_the_nearest_free_region() {
        // wall at 0.5 m over -10..+10: front blocked; region 1 (|cost| 1) free and
        // checked before region 7 -> region 1, angular +0.7, reverse -0.1
        let d = sectors_decide(
            &sweep(|i| if i <= 10 || i >= 350 { 0.5 } else { INF }),
            0.0,
            &SectorParams::default(),
        )
        .unwrap();
        assert!(d.obstacle_detected);
        assert_eq!(d.region, 1);
        assert_eq!((d.linear_velocity, d.angular_velocity), (-0.1, 0.7));
        assert_eq!(d.nearest_m[0], 0.5);

        // a beam at 25 deg lies in front and region 1: both blocked -> region 7, turn right
        let d = sectors_decide(
            &sweep(|i| if i == 25 { 0.5 } else { INF }),
            0.0,
            &SectorParams::default(),
        )
        .unwrap();
        assert!(d.obstacle_detected);
        assert!(!d.free[1]);
        assert_eq!(d.region, 7);
        assert_eq!(d.angular_velocity, -0.7);

        // front, 1, 7, 2 blocked -> region 6 (cost -2, |2| ties with 2 but 2 is blocked)
        let d = sectors_decide(
            &sweep(|i| if i <= 112 || i >= 300 { 0.8 } else { INF }),
            0.0,
            &SectorParams::default(),
        )
        .unwrap();
        assert_eq!(d.region, 6);
        assert_eq!(d.angular_velocity, -0.7);
    }

    #[test]
    fn all_blocked_goes_to_the_farthest_reading() {
        // every beam 0.3 m except the right region (255..285 centred 270) at 0.9 m:
        // no region free -> region 6 (farthest 0.9), cost -2 -> angular -0.7
        let d = sectors_decide(
            &sweep(|i| if (255..285).contains(&i) { 0.9 } else { 0.3 }),
            0.0,
            &SectorParams::default(),
        )
        .unwrap();
        assert!(d.obstacle_detected);
        assert!(d.free.iter().all(|f| !f));
        assert_eq!(d.region, 6);
        assert_eq!(d.angular_velocity, -0.7);
        assert_eq!(d.linear_velocity, -0.1);

        // all equal -> first region with the max (front, cost 0): reverse, no turn
        let d = sectors_decide(&sweep(|_| 0.3), 0.0, &SectorParams::default()).unwrap();
        assert_eq!(d.region, 0);
        assert_eq!((d.linear_velocity, d.angular_velocity), (-0.1, 0.0));
    }

    #[test]
    fn readings_are_filtered_like_the_seed() {
        // inf, NaN, <= range_min (0.1) and > obj_threshold (1.0) do not count
        let p = SectorParams::default().with_range_min_m(0.1);
        let r = sweep(|i| match i {
            0 => f64::NAN,
            1 => 0.1,
            2 => 0.05,
            3 => 1.5,
            4 => -1.0,
            _ => INF,
        });
        let d = sectors_decide(&r, 0.0, &p).unwrap();
        assert!(!d.obstacle_detected);
        // 1.0 exactly counts (<= threshold)
        let d = sectors_decide(&sweep(|i| if i == 0 { 1.0 } else { INF }), 0.0, &p).unwrap();
        assert!(d.obstacle_detected);
    }

    #[test]
    fn angle_min_and_sparse_scans_are_handled() {
        // 8 beams starting at -180: bearings -180, -135, ..., 135; the one at 0 (index 4) blocked
        let mut r = [INF; 8];
        r[4] = 0.5;
        let d = sectors_decide(&r, -180.0, &SectorParams::default()).unwrap();
        assert!(d.obstacle_detected);
        assert_eq!(d.region, 1);
        assert!(matches!(
            sectors_decide(&[], 0.0, &SectorParams::default()),
            Err(SectorError::EmptyScan)
        ));
        assert!(matches!(
            sectors_decide(&r, f64::NAN, &SectorParams::default()),
            Err(SectorError::NonFiniteAngleMin)
        ));
    }
}
