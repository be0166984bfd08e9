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

mod params;
pub use params::{MAX_SCAN_RADII, OffsetError, OffsetParams};

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
mod tests;
