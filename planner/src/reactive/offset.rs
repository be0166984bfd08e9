//! The Offset Algorithm (seed 000 "Offset Algorithm", seed 001 section 3): pick a lateral
//! escape direction from one 2-D LiDAR sweep.
//!
//! # Algorithm
//!
//! 1. **Beams in the field of view.** Bearings are wrapped to `(-180, 180]`, beams with
//!    `|angle| <= fov_deg / 2` are kept and sorted by bearing, so index 0 is the rightmost
//!    beam and the last index the leftmost (left = counter-clockwise = positive).
//! 2. **Frames.** For each scan radius `R_j` (sorted ascending, so frame 0 is the nearest)
//!    a frame of nanoboxes: `1` when the beam's distance is `<= R_j`, else `0`.
//!    Readings are classified first:
//!    - `NaN`, `+inf`, or `> range_max_m`: *no return*, free (`0`) in every frame. A LiDAR
//!      reports these when nothing reflects within its range, which is the free case.
//!    - `< range_min_m` (this includes every negative value and `-inf`): *blocked* (`1`) in
//!      every frame. A reading below the sensor's minimum range means something is too
//!      close to measure or the window is obscured; a safety avoider must not fly into it,
//!      so the conservative choice is made (seed 003's sector avoider drops such readings
//!      instead, see [`super::sectors`]).
//! 3. **Scan windows** of `N = window` consecutive nanoboxes. With `L` beams in view, at
//!    cycle `k` the left window is beams `[floor(L/2) + k, floor(L/2) + k + N)` and the
//!    right window is beams `[ceil(L/2) - k - N, ceil(L/2) - k)`: mirror images of each
//!    other, both touching the heading at cycle 0 (with an odd `L` both contain the
//!    centre beam), both stepping one beam outward per cycle, for
//!    `ceil(L/2) - N + 1` cycles.
//! 4. **Scores.** Scan score `S = sum(n_i * 100 / N)` (the window's blocked percentage),
//!    frame weight `w_j = 2^(n-j) / (2^n - 1)` for frame `j = 1..n` ([`frame_weight`],
//!    nearest heaviest, weights sum to 1), aggregate `A = sum_j w_j * S_j` in `[0, 100]`.
//! 5. **Decision**, per cycle, stopping at the first cycle that decides (early termination):
//!    - cycle 0 and both `A_left <= T` and `A_right <= T`: **LEFT** ("first-cycle tie"); the
//!      two windows together straddle the heading and are clear, so the way ahead is clear
//!      and the reported deviation is 0;
//!    - both `<= T`: the lower aggregate wins (an exact tie goes LEFT);
//!    - only one `<= T`: that side;
//!    - neither: next cycle. After the last cycle: no path (`direction = None`).
//! 6. **Output.** The chosen window's centre bearing `theta` (mean of its outer beams'
//!    bearings) is the heading change, and the lateral deviation is
//!    `lookahead_m * sin(theta)` (the window centre's lateral offset at the look-ahead
//!    range, default the largest scan radius), positive to the left.
//!
//! # Corrections to the seed's Python (seed 000, "Implementation Python")
//!
//! - `score_window`: `(value * 100) // N` is integer division and `N = len(slice)`; the text
//!   defines `S = sum(n_i * 100 / N)` with the configured `N`. Here scores are real-valued
//!   and always divide by the configured window size (windows are never truncated, see next).
//! - `scan_box` / `__init__`: the bounds are asymmetric (`last_pos_L = mid + 2` gives the left
//!   slice `[mid-1, mid+3)`, `last_pos_R = mid - 1` gives `[mid-1, mid+3)` too: both windows
//!   start on the same beams), the `max(0, ..)` / `min(len, ..)` clamps silently shrink a
//!   window at the frame edge, and the advance step (`last_pos_L -= 1`, `last_pos_R += 1`)
//!   moves the *left* window toward lower indices, i.e. toward the right-hand beams of the
//!   seed's own ascending `-60..60` sample data. Here the windows are the mirror images
//!   described in step 3, always exactly `N` wide, moving outward on their own sides, and
//!   the cycle count is derived from the frame length instead of `k < mid`.
//! - `run`, decision block: the `print("=> Exhausted ...")` / `return None` lines are
//!   indented inside the `while` body, so the seed gives up after cycle 0 whenever no side
//!   passes, and the advance step sits in the `else` branch. Here the window advances after
//!   every undecided cycle and "no path" is returned only after the last cycle.
//! - `run`, both below threshold: `"LEFT" if Wl < Wr else "RIGHT"` sends an exact tie right;
//!   here an exact tie goes left, consistent with the first-cycle rule.
//! - `__main__`: the example radii `[1.0, 2.0, 3.0, 0.5, 5.0, 15.0, 20.0]` are unsorted while
//!   the weights assume index 0 is the nearest frame; the class sorts them and so does this
//!   code ([`OffsetWorkspace::radii_m`]).
//! - The per-frame `print`s sit outside their `for` loop in the extracted text (they print
//!   only the last frame); nothing here prints.
//!
//! # Example
//!
//! ```
//! use planner::reactive::{Beam, OffsetParams, Side, offset_decide};
//!
//! // 11 beams, -50..50 degrees; the beam at -10 degrees sees something 0.5 m away.
//! let scan: Vec<Beam> = (0..11)
//!     .map(|i| {
//!         let a = -50.0 + 10.0 * i as f64;
//!         Beam::new(a, if a == -10.0 { 0.5 } else { f64::INFINITY })
//!     })
//!     .collect();
//! let params = OffsetParams::default().with_scan_radii_m(vec![1.0, 2.0, 4.0]);
//! let d = offset_decide(&scan, &params).unwrap();
//! assert_eq!(d.direction, Some(Side::Left));
//! assert_eq!(d.cycle, 0);
//! ```

use super::{Beam, Side, wrap_deg_pm180};

/// Most scan radii accepted (the weights use `2^n`).
pub const MAX_SCAN_RADII: usize = 60;

/// Parameters of the Offset Algorithm.
///
/// Defaults: the seed's example radii `[0.5, 1, 2, 3, 5, 15, 20]` m, threshold 5.0, window 4,
/// field of view 120 degrees (the seed's `-60..60`), `range_min_m` 0, `range_max_m` infinite,
/// look-ahead = the largest scan radius.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct OffsetParams {
    /// Scan radii in metres, one frame each, any order (sorted internally).
    pub scan_radii_m: Vec<f64>,
    /// Threshold `T` on the aggregate score (0..100); a side passes when `A <= T`.
    pub threshold: f64,
    /// Window size `N` in beams (the minimum fly-through gap).
    pub window: usize,
    /// Field of view in degrees, centred on the heading, in `(0, 360]`.
    pub fov_deg: f64,
    /// Readings below this are treated as blocked (see the module docs).
    pub range_min_m: f64,
    /// Readings above this are treated as free (no return).
    pub range_max_m: f64,
    /// Range at which the window's lateral deviation is measured; `None` = largest radius.
    pub lookahead_m: Option<f64>,
}

impl Default for OffsetParams {
    fn default() -> Self {
        Self {
            scan_radii_m: vec![0.5, 1.0, 2.0, 3.0, 5.0, 15.0, 20.0],
            threshold: 5.0,
            window: 4,
            fov_deg: 120.0,
            range_min_m: 0.0,
            range_max_m: f64::INFINITY,
            lookahead_m: None,
        }
    }
}

impl OffsetParams {
    /// Set the scan radii (metres, any order).
    pub fn with_scan_radii_m(mut self, radii_m: Vec<f64>) -> Self {
        self.scan_radii_m = radii_m;
        self
    }
    /// Set the threshold `T`.
    pub fn with_threshold(mut self, threshold: f64) -> Self {
        self.threshold = threshold;
        self
    }
    /// Set the window size `N` (beams).
    pub fn with_window(mut self, window: usize) -> Self {
        self.window = window;
        self
    }
    /// Set the field of view (degrees).
    pub fn with_fov_deg(mut self, fov_deg: f64) -> Self {
        self.fov_deg = fov_deg;
        self
    }
    /// Set the sensor's valid range `[min, max]` in metres.
    pub fn with_range_m(mut self, range_min_m: f64, range_max_m: f64) -> Self {
        self.range_min_m = range_min_m;
        self.range_max_m = range_max_m;
        self
    }
    /// Set the look-ahead range for the deviation (metres).
    pub fn with_lookahead_m(mut self, lookahead_m: f64) -> Self {
        self.lookahead_m = Some(lookahead_m);
        self
    }

    /// Check the parameters (the scan is checked by [`OffsetWorkspace::decide`]).
    ///
    /// # Errors
    /// The [`OffsetError`] naming the first bad parameter.
    pub fn validate(&self) -> Result<(), OffsetError> {
        if self.scan_radii_m.is_empty() {
            return Err(OffsetError::NoScanRadii);
        }
        if self.scan_radii_m.len() > MAX_SCAN_RADII {
            return Err(OffsetError::TooManyScanRadii {
                count: self.scan_radii_m.len(),
            });
        }
        for (index, &value) in self.scan_radii_m.iter().enumerate() {
            if !(value.is_finite() && value > 0.0) {
                return Err(OffsetError::InvalidScanRadius { index, value });
            }
        }
        if !(self.threshold.is_finite() && self.threshold >= 0.0) {
            return Err(OffsetError::InvalidThreshold(self.threshold));
        }
        if self.window == 0 {
            return Err(OffsetError::ZeroWindow);
        }
        if !(self.fov_deg.is_finite() && self.fov_deg > 0.0 && self.fov_deg <= 360.0) {
            return Err(OffsetError::InvalidFov(self.fov_deg));
        }
        if !(self.range_min_m.is_finite()
            && self.range_min_m >= 0.0
            && !self.range_max_m.is_nan()
            && self.range_max_m > self.range_min_m)
        {
            return Err(OffsetError::InvalidRange {
                min_m: self.range_min_m,
                max_m: self.range_max_m,
            });
        }
        if let Some(l) = self.lookahead_m
            && !(l.is_finite() && l > 0.0)
        {
            return Err(OffsetError::InvalidLookahead(l));
        }
        Ok(())
    }
}

/// Bad input to the Offset Algorithm. "No path" is not an error: it is
/// [`OffsetDecision::direction`] `== None`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OffsetError {
    /// No scan radii: give at least one.
    #[error("scan_radii_m is empty: give at least one scan radius")]
    NoScanRadii,
    /// Too many scan radii: merge some (the weights of far frames underflow anyway).
    #[error("{count} scan radii exceed the maximum of {MAX_SCAN_RADII}")]
    TooManyScanRadii {
        /// How many were given.
        count: usize,
    },
    /// A radius is not a positive finite number: fix that entry.
    #[error("scan_radii_m[{index}] = {value} is not a positive finite number")]
    InvalidScanRadius {
        /// Index in the caller's list.
        index: usize,
        /// The bad value.
        value: f64,
    },
    /// The threshold is negative or not finite.
    #[error("threshold {0} is not a finite number >= 0")]
    InvalidThreshold(f64),
    /// Window size 0: use at least 1 beam.
    #[error("window must be at least 1 beam")]
    ZeroWindow,
    /// Field of view outside `(0, 360]` degrees.
    #[error("fov_deg {0} is not in (0, 360]")]
    InvalidFov(f64),
    /// Sensor range limits are not `0 <= min < max`.
    #[error("sensor range [{min_m}, {max_m}] m is not 0 <= min < max")]
    InvalidRange {
        /// `range_min_m`.
        min_m: f64,
        /// `range_max_m`.
        max_m: f64,
    },
    /// Look-ahead range not positive and finite.
    #[error("lookahead_m {0} is not a positive finite number")]
    InvalidLookahead(f64),
    /// The scan has no beams: send the sweep.
    #[error("the scan is empty")]
    EmptyScan,
    /// A beam's bearing is NaN or infinite: fix or drop that beam.
    #[error("scan[{index}].angle_deg is not finite")]
    NonFiniteAngle {
        /// Index in the caller's scan.
        index: usize,
    },
    /// Fewer beams in the field of view than one window on each side of the heading needs:
    /// widen the field of view, use a denser scan or a smaller window.
    #[error("{in_fov} beams in the field of view; a window of {window} needs at least {needed}")]
    TooFewBeams {
        /// Beams found within the field of view.
        in_fov: usize,
        /// The window size.
        window: usize,
        /// Beams needed (`2 * window - 1`).
        needed: usize,
    },
}

/// The window the decision chose, in the sorted in-view beam order.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ScanWindow {
    /// First beam index (0 = rightmost beam in view).
    pub first_beam: usize,
    /// Last beam index, inclusive.
    pub last_beam: usize,
    /// Bearing of the window's rightmost beam (degrees).
    pub right_edge_deg: f64,
    /// Bearing of the window's leftmost beam (degrees).
    pub left_edge_deg: f64,
    /// Mean of the two edge bearings (degrees).
    pub centre_deg: f64,
}

/// The Offset Algorithm's answer for one sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct OffsetDecision {
    /// The side to go, or `None` when every cycle failed the threshold (no path).
    pub direction: Option<Side>,
    /// The cycle that decided (0-based), or the last cycle evaluated when there is no path.
    pub cycle: usize,
    /// How many cycles were evaluated.
    pub cycles_evaluated: usize,
    /// Left aggregate score `A` at `cycle` (0..100).
    pub aggregate_left: f64,
    /// Right aggregate score `A` at `cycle` (0..100).
    pub aggregate_right: f64,
    /// The chosen window (`None` when there is no path).
    pub window: Option<ScanWindow>,
    /// True on a first-cycle tie: both windows at the heading are clear, no deviation needed.
    pub way_ahead_clear: bool,
    /// Heading change toward the chosen window's centre, degrees, left positive (0 when the
    /// way ahead is clear or there is no path).
    pub heading_change_deg: f64,
    /// Lateral deviation in metres, left positive: `lookahead * sin(heading_change)`.
    pub deviation_m: f64,
}

/// Weight of frame `i` (1-based, 1 = nearest) among `n` frames: `2^(n-i) / (2^n - 1)`.
///
/// The weights of frames `1..=n` sum to 1 (a geometric series), and each frame weighs
/// twice the next farther one.
///
/// # Panics
/// If `i` is 0 or greater than `n`.
pub fn frame_weight(n: usize, i: usize) -> f64 {
    assert!(i >= 1 && i <= n, "frame index {i} not in 1..={n}");
    // exponents are small (n <= MAX_SCAN_RADII), so powi is exact
    2f64.powi((n - i) as i32) / (2f64.powi(n as i32) - 1.0)
}

/// Reusable buffers for the Offset Algorithm, so that a control loop allocates nothing after
/// its first cycle.
#[derive(Debug, Clone, Default)]
pub struct OffsetWorkspace {
    /// In-view beams as (bearing, effective distance): free = +inf, blocked = -inf.
    beams: Vec<(f64, f64)>,
    radii_m: Vec<f64>,
    weights: Vec<f64>,
    /// Frame-major nanoboxes: `frames[j * L + i]`.
    frames: Vec<u8>,
}

impl OffsetWorkspace {
    /// An empty workspace.
    pub fn new() -> Self {
        Self::default()
    }

    /// The sorted scan radii of the last [`decide`](Self::decide) call (frame `j` uses `radii_m()[j]`).
    pub fn radii_m(&self) -> &[f64] {
        &self.radii_m
    }

    /// Number of beams in view in the last call (the frame length `L`).
    pub fn frame_len(&self) -> usize {
        self.beams.len()
    }

    /// Frame `j` (0 = nearest radius) of the last call: one nanobox per in-view beam, index 0
    /// the rightmost beam.
    ///
    /// # Panics
    /// If `j` is not below the number of radii.
    pub fn frame(&self, j: usize) -> &[u8] {
        let l = self.beams.len();
        &self.frames[j * l..(j + 1) * l]
    }

    /// Bearings (degrees) of the in-view beams of the last call, ascending.
    pub fn bearings_deg(&self) -> impl Iterator<Item = f64> + '_ {
        self.beams.iter().map(|b| b.0)
    }

    /// Run the Offset Algorithm on one sweep, reusing this workspace's buffers.
    ///
    /// # Errors
    /// [`OffsetError`] for bad parameters or an unusable scan (empty, non-finite bearing,
    /// fewer than `2 * window - 1` beams in view). No path is `Ok` with `direction: None`.
    pub fn decide(
        &mut self,
        scan: &[Beam],
        params: &OffsetParams,
    ) -> Result<OffsetDecision, OffsetError> {
        params.validate()?;
        if scan.is_empty() {
            return Err(OffsetError::EmptyScan);
        }
        let half_fov = params.fov_deg / 2.0;
        self.beams.clear();
        for (index, beam) in scan.iter().enumerate() {
            if !beam.angle_deg.is_finite() {
                return Err(OffsetError::NonFiniteAngle { index });
            }
            let a = wrap_deg_pm180(beam.angle_deg);
            if a.abs() <= half_fov + 1e-9 {
                self.beams
                    .push((a, effective_distance(beam.distance_m, params)));
            }
        }
        let l = self.beams.len();
        let n_win = params.window;
        let half_up = l.div_ceil(2);
        if half_up < n_win {
            return Err(OffsetError::TooFewBeams {
                in_fov: l,
                window: n_win,
                needed: 2 * n_win - 1,
            });
        }
        let by_bearing =
            |a: &(f64, f64), b: &(f64, f64)| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1));
        if !self.beams.is_sorted_by(|a, b| by_bearing(a, b).is_le()) {
            self.beams.sort_unstable_by(by_bearing);
        }

        self.radii_m.clear();
        self.radii_m.extend_from_slice(&params.scan_radii_m);
        self.radii_m.sort_unstable_by(f64::total_cmp);
        let n_frames = self.radii_m.len();
        self.weights.clear();
        self.weights
            .extend((1..=n_frames).map(|i| frame_weight(n_frames, i)));

        self.frames.clear();
        self.frames.reserve(n_frames * l);
        for &r in &self.radii_m {
            self.frames
                .extend(self.beams.iter().map(|&(_, d)| u8::from(d <= r)));
        }

        let cycles = half_up - n_win + 1;
        let left0 = l / 2;
        let mut last = (0.0, 0.0);
        for k in 0..cycles {
            let left_start = left0 + k;
            let right_start = half_up - k - n_win;
            let a_left = self.aggregate(left_start, n_win);
            let a_right = self.aggregate(right_start, n_win);
            last = (a_left, a_right);
            let t = params.threshold;
            let chosen = match (a_left <= t, a_right <= t) {
                (true, true) if k == 0 => {
                    return Ok(OffsetDecision {
                        direction: Some(Side::Left),
                        cycle: 0,
                        cycles_evaluated: 1,
                        aggregate_left: a_left,
                        aggregate_right: a_right,
                        window: Some(self.window_at(left_start, n_win)),
                        way_ahead_clear: true,
                        heading_change_deg: 0.0,
                        deviation_m: 0.0,
                    });
                }
                (true, true) if a_right < a_left => Some((Side::Right, right_start)),
                (true, _) => Some((Side::Left, left_start)),
                (false, true) => Some((Side::Right, right_start)),
                (false, false) => None,
            };
            if let Some((side, start)) = chosen {
                let window = self.window_at(start, n_win);
                let lookahead_m = params.lookahead_m.unwrap_or(self.radii_m[n_frames - 1]);
                return Ok(OffsetDecision {
                    direction: Some(side),
                    cycle: k,
                    cycles_evaluated: k + 1,
                    aggregate_left: a_left,
                    aggregate_right: a_right,
                    window: Some(window),
                    way_ahead_clear: false,
                    heading_change_deg: window.centre_deg,
                    deviation_m: lookahead_m * window.centre_deg.to_radians().sin(),
                });
            }
        }
        Ok(OffsetDecision {
            direction: None,
            cycle: cycles - 1,
            cycles_evaluated: cycles,
            aggregate_left: last.0,
            aggregate_right: last.1,
            window: None,
            way_ahead_clear: false,
            heading_change_deg: 0.0,
            deviation_m: 0.0,
        })
    }

    /// `A = sum_j w_j * S_j` for the window `[start, start + n)`.
    fn aggregate(&self, start: usize, n: usize) -> f64 {
        let l = self.beams.len();
        let mut a = 0.0;
        for (j, w) in self.weights.iter().enumerate() {
            let frame = &self.frames[j * l + start..j * l + start + n];
            let blocked: u32 = frame.iter().map(|&b| u32::from(b)).sum();
            // S = sum(n_i * 100 / N)
            a += w * (f64::from(blocked) * 100.0 / n as f64);
        }
        a
    }

    fn window_at(&self, start: usize, n: usize) -> ScanWindow {
        let right = self.beams[start].0;
        let left = self.beams[start + n - 1].0;
        ScanWindow {
            first_beam: start,
            last_beam: start + n - 1,
            right_edge_deg: right,
            left_edge_deg: left,
            centre_deg: (right + left) / 2.0,
        }
    }
}

/// Map a reading to the distance compared against each radius: `+inf` = free in every
/// frame, `-inf` = blocked in every frame.
fn effective_distance(distance_m: f64, params: &OffsetParams) -> f64 {
    if distance_m.is_nan() || distance_m > params.range_max_m {
        f64::INFINITY
    } else if distance_m < params.range_min_m {
        f64::NEG_INFINITY
    } else {
        distance_m
    }
}

/// Run the Offset Algorithm once with a fresh workspace (allocates; use
/// [`OffsetWorkspace::decide`] in a loop).
///
/// # Errors
/// As [`OffsetWorkspace::decide`].
pub fn offset_decide(scan: &[Beam], params: &OffsetParams) -> Result<OffsetDecision, OffsetError> {
    OffsetWorkspace::new().decide(scan, params)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    const INF: f64 = f64::INFINITY;

    /// 11 beams at -50, -40, ..., +50 degrees (index i at -50 + 10 i), all free.
    /// L = 11: left windows start at floor(11/2) + k = 5 + k, right windows at
    /// ceil(11/2) - k - 4 = 2 - k; cycles = 6 - 4 + 1 = 3.
    fn eleven(dist: &[(usize, f64)]) -> Vec<Beam> {
        let mut scan: Vec<Beam> = (0..11)
            .map(|i| Beam::new(-50.0 + 10.0 * i as f64, INF))
            .collect();
        for &(i, d) in dist {
            scan[i].distance_m = d;
        }
        scan
    }

    fn params(radii: &[f64]) -> OffsetParams {
        OffsetParams::default().with_scan_radii_m(radii.to_vec())
    }

    #[test]
    fn weights_sum_to_one_and_halve_outward() {
        for n in 1..=20 {
            let s: f64 = (1..=n).map(|i| frame_weight(n, i)).sum();
            assert_relative_eq!(s, 1.0, epsilon = 1e-12);
        }
        // n = 3: 4/7, 2/7, 1/7
        assert_relative_eq!(frame_weight(3, 1), 4.0 / 7.0);
        assert_relative_eq!(frame_weight(3, 2), 2.0 / 7.0);
        assert_relative_eq!(frame_weight(3, 3), 1.0 / 7.0);
        // n = 1: the single frame weighs 2^0 / (2^1 - 1) = 1
        assert_relative_eq!(frame_weight(1, 1), 1.0);
    }

    #[test]
    fn frames_are_built_from_unsorted_radii_nearest_first() {
        // radii given as [4, 1, 2] -> sorted [1, 2, 4]
        let scan = eleven(&[(0, 0.5), (1, 1.5), (2, 3.0), (3, 5.0), (4, 1.0)]);
        let mut ws = OffsetWorkspace::new();
        ws.decide(&scan, &params(&[4.0, 1.0, 2.0])).unwrap();
        assert_eq!(ws.radii_m(), &[1.0, 2.0, 4.0]);
        // beam 0 (0.5) blocked in all; 1 (1.5) from R=2; 2 (3.0) only R=4; 3 (5.0) never;
        // 4 (1.0) in all (d <= R is inclusive); the rest inf -> free
        assert_eq!(ws.frame(0), &[1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0]);
        assert_eq!(ws.frame(1), &[1, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0]);
        assert_eq!(ws.frame(2), &[1, 1, 1, 0, 1, 0, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn beams_are_sorted_by_bearing_and_filtered_by_fov() {
        // given left to right and with a 300-degree bearing (= -60) and one outside +-60
        let scan = vec![
            Beam::new(50.0, 0.5),
            Beam::new(300.0, INF),
            Beam::new(-70.0, 0.5),
            Beam::new(0.0, INF),
            Beam::new(-30.0, INF),
            Beam::new(20.0, INF),
            Beam::new(-10.0, 0.5),
        ];
        let mut ws = OffsetWorkspace::new();
        ws.decide(&scan, &params(&[1.0]).with_window(2)).unwrap();
        let b: Vec<f64> = ws.bearings_deg().collect();
        assert_eq!(b, vec![-60.0, -30.0, -10.0, 0.0, 20.0, 50.0]);
        assert_eq!(ws.frame(0), &[0, 0, 1, 0, 0, 1]);
    }

    #[test]
    fn unusual_readings_nan_inf_far_are_free_and_below_min_is_blocked() {
        // indices 0..4: NaN, +inf, 30 m (> range_max 25), -1 (negative), 0.05 (< range_min 0.1)
        let scan = eleven(&[
            (0, f64::NAN),
            (1, INF),
            (2, 30.0),
            (3, -1.0),
            (4, 0.05),
            (5, f64::NEG_INFINITY),
        ]);
        let mut ws = OffsetWorkspace::new();
        ws.decide(&scan, &params(&[1.0, 50.0]).with_range_m(0.1, 25.0))
            .unwrap();
        assert_eq!(ws.frame(0), &[0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 0]);
        // 30 m is beyond range_max so free even in the 50 m frame
        assert_eq!(ws.frame(1), &[0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn first_cycle_tie_goes_left_even_when_right_is_lower() {
        // radii [1, 2, 4]: weights 4/7, 2/7, 1/7.
        // beam 8 (+30 deg) at 3.0 m: blocked only in the R=4 frame.
        // cycle 0: left window beams 5..=8 -> S = (0, 0, 25) -> A_L = 25/7 = 3.571 <= 5
        //          right window beams 2..=5 -> A_R = 0 <= 5  -> both pass at cycle 0 -> LEFT
        let d = offset_decide(&eleven(&[(8, 3.0)]), &params(&[1.0, 2.0, 4.0])).unwrap();
        assert_eq!(d.direction, Some(Side::Left));
        assert_eq!(d.cycle, 0);
        assert!(d.way_ahead_clear);
        assert_relative_eq!(d.aggregate_left, 25.0 / 7.0, epsilon = 1e-12);
        assert_relative_eq!(d.aggregate_right, 0.0);
        assert_eq!(d.deviation_m, 0.0);
        assert_eq!(d.heading_change_deg, 0.0);
    }

    #[test]
    fn only_left_passes() {
        // beam 4 (-10 deg) at 0.5 m: blocked in every frame.
        // cycle 0: right window 2..=5 has one blocked -> S = 25 in each frame -> A_R = 25 > 5
        //          left window 5..=8 is clear -> A_L = 0 -> LEFT at cycle 0 (not a tie)
        // window 5..=8 = 0..30 deg, centre 15 deg; look-ahead = largest radius 4 m
        // deviation = 4 sin 15 deg = 1.03528 m
        let d = offset_decide(&eleven(&[(4, 0.5)]), &params(&[1.0, 2.0, 4.0])).unwrap();
        assert_eq!(d.direction, Some(Side::Left));
        assert_eq!(d.cycle, 0);
        assert!(!d.way_ahead_clear);
        assert_relative_eq!(d.aggregate_right, 25.0, epsilon = 1e-12);
        assert_eq!(d.aggregate_left, 0.0);
        let w = d.window.unwrap();
        assert_eq!((w.first_beam, w.last_beam), (5, 8));
        assert_relative_eq!(d.heading_change_deg, 15.0);
        assert_relative_eq!(
            d.deviation_m,
            4.0 * 15f64.to_radians().sin(),
            epsilon = 1e-12
        );
        assert_relative_eq!(d.deviation_m, 1.035276, epsilon = 1e-6);
    }

    #[test]
    fn only_right_passes() {
        // mirror of only_left_passes: beam 6 (+10 deg) blocked -> left window 5..=8 has A_L = 25
        // right window 2..=5 = -30..0 deg clear -> RIGHT, centre -15 deg, deviation -1.03528 m
        let d = offset_decide(&eleven(&[(6, 0.5)]), &params(&[1.0, 2.0, 4.0])).unwrap();
        assert_eq!(d.direction, Some(Side::Right));
        assert_eq!(d.cycle, 0);
        assert_relative_eq!(d.aggregate_left, 25.0, epsilon = 1e-12);
        let w = d.window.unwrap();
        assert_eq!((w.first_beam, w.last_beam), (2, 5));
        assert_relative_eq!(d.heading_change_deg, -15.0);
        assert_relative_eq!(d.deviation_m, -1.035276, epsilon = 1e-6);
    }

    #[test]
    fn both_pass_later_and_the_lower_wins() {
        // radii [1, 2, 4, 8]: weights 8/15, 4/15, 2/15, 1/15.
        // beam 5 (0 deg) at 0.5 m: in both cycle-0 windows, S = 25 everywhere -> A = 25 > 5.
        // cycle 1: left 6..=9, right 1..=4.
        //   beam 9 (+40) at 3.0 m: blocked in R=4, R=8 -> A_L = 25 * (2 + 1) / 15 = 5.0 <= 5
        //   beam 1 (-40) at 6.0 m: blocked in R=8 only -> A_R = 25 * 1 / 15 = 1.667 <= 5
        // both pass, right lower -> RIGHT at cycle 1; window 1..=4 = -40..-10, centre -25 deg
        // deviation = 8 sin(-25 deg) = -3.38095 m
        let scan = eleven(&[(5, 0.5), (9, 3.0), (1, 6.0)]);
        let d = offset_decide(&scan, &params(&[1.0, 2.0, 4.0, 8.0])).unwrap();
        assert_eq!(d.direction, Some(Side::Right));
        assert_eq!(d.cycle, 1);
        assert_eq!(d.cycles_evaluated, 2);
        assert_relative_eq!(d.aggregate_left, 5.0, epsilon = 1e-12);
        assert_relative_eq!(d.aggregate_right, 25.0 / 15.0, epsilon = 1e-12);
        assert_relative_eq!(d.heading_change_deg, -25.0);
        assert_relative_eq!(d.deviation_m, -3.380946, epsilon = 1e-6);

        // swap the sides: beam 1 at 3.0, beam 9 at 6.0 -> LEFT, centre (10 + 40) / 2 = 25 deg
        let scan = eleven(&[(5, 0.5), (1, 3.0), (9, 6.0)]);
        let d = offset_decide(&scan, &params(&[1.0, 2.0, 4.0, 8.0])).unwrap();
        assert_eq!(d.direction, Some(Side::Left));
        assert_eq!(d.cycle, 1);
        assert_relative_eq!(d.heading_change_deg, 25.0);

        // equal aggregates after cycle 0 (both 6.0 m -> 1.667 each) go LEFT
        let scan = eleven(&[(5, 0.5), (1, 6.0), (9, 6.0)]);
        let d = offset_decide(&scan, &params(&[1.0, 2.0, 4.0, 8.0])).unwrap();
        assert_eq!(d.direction, Some(Side::Left));
        assert_eq!(d.cycle, 1);
    }

    #[test]
    fn exhausted_scan_has_no_path() {
        // every beam at 0.5 m: every window S = 100 in every frame -> A = 100 > 5 for all
        // 3 cycles -> no path, aggregates of the last cycle reported
        let scan: Vec<Beam> = eleven(&[])
            .into_iter()
            .map(|b| Beam::new(b.angle_deg, 0.5))
            .collect();
        let d = offset_decide(&scan, &params(&[1.0, 2.0, 4.0])).unwrap();
        assert_eq!(d.direction, None);
        assert_eq!(d.cycles_evaluated, 3);
        assert_eq!(d.cycle, 2);
        assert_relative_eq!(d.aggregate_left, 100.0, epsilon = 1e-12);
        assert_relative_eq!(d.aggregate_right, 100.0, epsilon = 1e-12);
        assert_eq!(d.window, None);
        assert_eq!(d.deviation_m, 0.0);
    }

    #[test]
    fn the_last_cycle_reaches_the_outermost_beams() {
        // only beams 7..=10 (+20..+50) free; the rest at 0.5 m.
        // cycle 2 left window = 7..=10 -> A_L = 0 -> LEFT at cycle 2, centre 35 deg
        let mut scan: Vec<Beam> = eleven(&[])
            .into_iter()
            .map(|b| Beam::new(b.angle_deg, 0.5))
            .collect();
        for b in &mut scan[7..] {
            b.distance_m = INF;
        }
        let d = offset_decide(&scan, &params(&[1.0])).unwrap();
        assert_eq!(d.direction, Some(Side::Left));
        assert_eq!(d.cycle, 2);
        assert_relative_eq!(d.heading_change_deg, 35.0);
    }

    #[test]
    fn even_beam_counts_split_at_the_heading() {
        // 10 beams at -45..45 step 10 (no centre beam): L = 10, left windows start at 5 + k,
        // right windows at 5 - k - 4 = 1 - k; cycles = 5 - 4 + 1 = 2.
        // beam 5 (+5 deg) blocked -> left 5..=8 fails; right 1..=4 (-35..-5) clear -> RIGHT,
        // centre -20 deg
        let scan: Vec<Beam> = (0..10)
            .map(|i| {
                let a = -45.0 + 10.0 * i as f64;
                Beam::new(a, if i == 5 { 0.5 } else { INF })
            })
            .collect();
        let d = offset_decide(&scan, &params(&[1.0])).unwrap();
        assert_eq!(d.direction, Some(Side::Right));
        assert_eq!(d.cycle, 0);
        assert_relative_eq!(d.heading_change_deg, -20.0);
    }

    #[test]
    fn bad_input_is_an_error() {
        let scan = eleven(&[]);
        let e = |p: OffsetParams| offset_decide(&scan, &p).unwrap_err();
        assert_eq!(e(params(&[])), OffsetError::NoScanRadii);
        assert!(matches!(
            e(params(&[1.0, -2.0])),
            OffsetError::InvalidScanRadius { index: 1, .. }
        ));
        assert_eq!(e(params(&[1.0]).with_window(0)), OffsetError::ZeroWindow);
        assert!(matches!(
            e(params(&[1.0]).with_fov_deg(0.0)),
            OffsetError::InvalidFov(_)
        ));
        assert!(matches!(
            e(params(&[1.0]).with_threshold(f64::NAN)),
            OffsetError::InvalidThreshold(_)
        ));
        assert_eq!(
            e(params(&[1.0]).with_window(7)),
            OffsetError::TooFewBeams {
                in_fov: 11,
                window: 7,
                needed: 13
            }
        );
        assert_eq!(
            offset_decide(&[], &params(&[1.0])).unwrap_err(),
            OffsetError::EmptyScan
        );
        let mut bad = scan.clone();
        bad[3].angle_deg = f64::NAN;
        assert_eq!(
            offset_decide(&bad, &params(&[1.0])).unwrap_err(),
            OffsetError::NonFiniteAngle { index: 3 }
        );
    }

    #[test]
    fn the_workspace_gives_the_same_answer_as_a_fresh_call() {
        let mut ws = OffsetWorkspace::new();
        let a = eleven(&[(4, 0.5)]);
        let b = eleven(&[(6, 0.5), (5, 0.7)]);
        let p = params(&[1.0, 2.0, 4.0]);
        for scan in [&a, &b, &a] {
            assert_eq!(
                ws.decide(scan, &p).unwrap(),
                offset_decide(scan, &p).unwrap()
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// One free corridor at least N beams wide lying on one side of the heading, every
        /// other beam blocked in every frame: the algorithm goes to that side, through a
        /// window inside the corridor.
        #[test]
        fn a_single_corridor_is_found_on_its_side(
            l in 12usize..90,
            n in 1usize..6,
            extra in 0usize..5,
            pos in 0.0f64..1.0,
            left in any::<bool>(),
            near in 0.01f64..0.99,
        ) {
            let half_up = l.div_ceil(2);
            prop_assume!(half_up >= n);
            let width = (n + extra).min(l / 2);
            prop_assume!(width >= n);
            // strictly one side: indices >= ceil(l/2) (left) or < floor(l/2) (right), so an
            // odd scan's centre beam (shared by both cycle-0 windows) stays blocked
            let (lo, hi) = if left { (half_up, l.saturating_sub(width)) } else { (0, (l / 2).saturating_sub(width)) };
            prop_assume!(hi >= lo && lo + width <= l);
            let start = lo + ((hi - lo) as f64 * pos).round() as usize;
            let step = 120.0 / l as f64;
            let scan: Vec<Beam> = (0..l)
                .map(|i| {
                    let a = -60.0 + step * (i as f64 + 0.5);
                    let free = (start..start + width).contains(&i);
                    Beam::new(a, if free { INF } else { near })
                })
                .collect();
            let p = OffsetParams::default().with_scan_radii_m(vec![1.0, 3.0, 9.0]).with_window(n);
            let d = offset_decide(&scan, &p).unwrap();
            let side = if left { Side::Left } else { Side::Right };
            prop_assert_eq!(d.direction, Some(side));
            let w = d.window.unwrap();
            prop_assert!(w.first_beam >= start && w.last_beam < start + width);
            prop_assert!(!d.way_ahead_clear);
            prop_assert!(d.deviation_m * side.sign() > 0.0);
        }
    }
}
