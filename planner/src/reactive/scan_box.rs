//! Scan box mechanics (seed 000, "The Offset Algorithm: Scan Box Mechanics"): slide a
//! fixed-size box left and right over a 2-D occupancy image until one is entirely free.
//!
//! # Geometry
//!
//! Aircraft-relative, `x_m` lateral (left positive), `y_m` forward. The [`OccupancyGrid`]
//! is centred laterally on the aircraft and starts at it: cell `(row, col)` covers
//! `x in [-W/2 + col * s, -W/2 + (col + 1) * s)` and `y in [row * s, (row + 1) * s)` with
//! cell size `s` and image width `W = cols * s` (so column 0 is the rightmost column, like
//! the lowest bearing of a scan).
//!
//! The box is `box_width_m` (lateral, default 1 m) by `box_length_m` (forward, default 2 m),
//! its near edge `box_start_m` ahead of the aircraft (default 0). At cycle `k` the left box
//! is centred on `x = +k * k_step_m` and the right box on `x = -k * k_step_m` (k_step 0.2 m);
//! at cycle 0 they coincide, centred on the heading. A box is free when every cell whose
//! centre lies inside it is free; cells outside the image are unknown and count as
//! occupied. The first cycle with a free box decides (both free: LEFT, the same tie rule
//! as [`super::offset`]); the search stops when the offset would exceed
//! `max_offset_fraction` (50%) of `sensor_range_m`.
//!
//! # Example
//! ```
//! use planner::reactive::{OccupancyGrid, ScanBoxParams, Side, scan_box_decide};
//! // 6 m x 4 m image at 0.1 m cells; a post 1 m wide straight ahead, 1 m away
//! let mut grid = OccupancyGrid::new(0.1, 60, 40).unwrap();
//! grid.fill_rect(-0.5, 0.5, 1.0, 1.5);
//! let d = scan_box_decide(&grid, &ScanBoxParams::default()).unwrap();
//! assert_eq!(d.direction, Some(Side::Left));
//! assert!((d.offset_m - 1.0).abs() < 1e-9); // the box (1 m wide) clears the post at 1.0 m
//! ```

use super::Side;

/// A 2-D occupancy image, row-major, `true` = occupied. See the module docs for the frame.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyGrid {
    cell_m: f64,
    cols: usize,
    rows: usize,
    cells: Vec<bool>,
}

impl OccupancyGrid {
    /// An all-free grid of `cols` (lateral) by `rows` (forward) cells of `cell_m` metres.
    ///
    /// # Errors
    /// [`ScanBoxError::InvalidGrid`] when the cell size is not positive or a dimension is 0.
    pub fn new(cell_m: f64, cols: usize, rows: usize) -> Result<Self, ScanBoxError> {
        if !(cell_m.is_finite() && cell_m > 0.0) || cols == 0 || rows == 0 {
            return Err(ScanBoxError::InvalidGrid);
        }
        Ok(Self {
            cell_m,
            cols,
            rows,
            cells: vec![false; cols * rows],
        })
    }

    /// A grid from row-major cells (`rows * cols` of them, row 0 nearest, column 0 rightmost).
    ///
    /// # Errors
    /// [`ScanBoxError::InvalidGrid`] when the sizes disagree or the cell size is bad.
    pub fn from_cells(
        cell_m: f64,
        cols: usize,
        rows: usize,
        cells: Vec<bool>,
    ) -> Result<Self, ScanBoxError> {
        let mut g = Self::new(cell_m, cols, rows)?;
        if cells.len() != cols * rows {
            return Err(ScanBoxError::InvalidGrid);
        }
        g.cells = cells;
        Ok(g)
    }

    /// Cell size, metres.
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }

    /// Lateral x (left positive) of column `col`'s centre.
    fn col_centre_x(&self, col: usize) -> f64 {
        -(self.cols as f64) * self.cell_m / 2.0 + (col as f64 + 0.5) * self.cell_m
    }

    /// Is cell `(row, col)` occupied? Out of range = occupied (unknown).
    pub fn occupied(&self, row: usize, col: usize) -> bool {
        row >= self.rows || col >= self.cols || self.cells[row * self.cols + col]
    }

    /// Mark `(row, col)` occupied or free (ignored outside the grid).
    pub fn set(&mut self, row: usize, col: usize, occupied: bool) {
        if row < self.rows && col < self.cols {
            self.cells[row * self.cols + col] = occupied;
        }
    }

    /// Mark occupied every cell whose centre lies in `x in [x0, x1]`, `y in [y0, y1]` (metres).
    pub fn fill_rect(&mut self, x0_m: f64, x1_m: f64, y0_m: f64, y1_m: f64) {
        for row in 0..self.rows {
            let y = (row as f64 + 0.5) * self.cell_m;
            if y < y0_m || y > y1_m {
                continue;
            }
            for col in 0..self.cols {
                let x = self.col_centre_x(col);
                if x >= x0_m && x <= x1_m {
                    self.cells[row * self.cols + col] = true;
                }
            }
        }
    }

    /// Is every cell whose centre lies in the box `x in [xc - w/2, xc + w/2]`,
    /// `y in [y0, y0 + len]` free? Parts of the box outside the image count as occupied.
    pub fn box_free(&self, x_centre_m: f64, width_m: f64, y0_m: f64, length_m: f64) -> bool {
        let s = self.cell_m;
        let half_w = self.cols as f64 * s / 2.0;
        let (x0, x1) = (x_centre_m - width_m / 2.0, x_centre_m + width_m / 2.0);
        let (y0, y1) = (y0_m, y0_m + length_m);
        let eps = 1e-9 * s;
        if x0 < -half_w - eps || x1 > half_w + eps || y0 < -eps || y1 > self.rows as f64 * s + eps {
            return false;
        }
        // cell index ranges whose centres are inside [lo, hi]: centre_i = lo_edge + (i + 0.5) s
        let idx = |lo: f64, hi: f64, origin: f64, n: usize| {
            let a = ((lo - origin) / s - 0.5 - 1e-9).ceil().max(0.0) as usize;
            let b = ((hi - origin) / s - 0.5 + 1e-9).floor();
            if b < 0.0 {
                return (a, 0);
            }
            (a, (b as usize + 1).min(n))
        };
        let (c0, c1) = idx(x0, x1, -half_w, self.cols);
        let (r0, r1) = idx(y0, y1, 0.0, self.rows);
        for row in r0..r1 {
            if self.cells[row * self.cols + c0..row * self.cols + c1.max(c0)]
                .iter()
                .any(|&c| c)
            {
                return false;
            }
        }
        true
    }
}

/// Scan box parameters. Defaults from the seed: box 1 m x 2 m, `k_step_m` 0.2, max offset
/// 50% of a 5 m sensor range (2.5 m), box starting at the aircraft.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanBoxParams {
    /// Box width (lateral), metres.
    pub box_width_m: f64,
    /// Box length (forward), metres.
    pub box_length_m: f64,
    /// Forward distance of the box's near edge, metres.
    pub box_start_m: f64,
    /// Lateral step per cycle, metres.
    pub k_step_m: f64,
    /// Sensor range, metres.
    pub sensor_range_m: f64,
    /// The largest offset tried is this fraction of the sensor range.
    pub max_offset_fraction: f64,
}

impl Default for ScanBoxParams {
    fn default() -> Self {
        Self {
            box_width_m: 1.0,
            box_length_m: 2.0,
            box_start_m: 0.0,
            k_step_m: 0.2,
            sensor_range_m: 5.0,
            max_offset_fraction: 0.5,
        }
    }
}

/// Bad scan box input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ScanBoxError {
    /// The grid's cell size is not positive, a dimension is 0, or the cells do not match.
    #[error(
        "occupancy grid: cell size must be positive, dimensions non-zero and cells = rows * cols"
    )]
    InvalidGrid,
    /// A parameter is not positive and finite (`box_start_m` may be 0).
    #[error("scan box parameter {name} = {value} is out of range")]
    InvalidParameter {
        /// Field name.
        name: &'static str,
        /// The bad value.
        value: f64,
    },
}

/// The scan box answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanBoxDecision {
    /// Side of the free box (`Left` also when the centred box at cycle 0 is free), `None`
    /// when no box within the range limit is free.
    pub direction: Option<Side>,
    /// Deciding cycle, or the number of cycles tried when there is none.
    pub cycle: usize,
    /// Lateral offset of the free box's centre, metres, left positive (0 at cycle 0).
    pub offset_m: f64,
}

/// Slide the boxes outward until one is free.
///
/// # Errors
/// [`ScanBoxError::InvalidParameter`] for a bad parameter.
pub fn scan_box_decide(
    grid: &OccupancyGrid,
    params: &ScanBoxParams,
) -> Result<ScanBoxDecision, ScanBoxError> {
    for (name, v, allow_zero) in [
        ("box_width_m", params.box_width_m, false),
        ("box_length_m", params.box_length_m, false),
        ("box_start_m", params.box_start_m, true),
        ("k_step_m", params.k_step_m, false),
        ("sensor_range_m", params.sensor_range_m, false),
        ("max_offset_fraction", params.max_offset_fraction, true),
    ] {
        if !(v.is_finite() && (v > 0.0 || (allow_zero && v == 0.0))) {
            return Err(ScanBoxError::InvalidParameter { name, value: v });
        }
    }
    let max_offset = params.max_offset_fraction * params.sensor_range_m;
    // k * step <= max_offset, with a little slack for the float division
    let cycles = (max_offset / params.k_step_m + 1e-9).floor() as usize + 1;
    let free_at = |x: f64| {
        grid.box_free(
            x,
            params.box_width_m,
            params.box_start_m,
            params.box_length_m,
        )
    };
    for k in 0..cycles {
        let off = k as f64 * params.k_step_m;
        if free_at(off) {
            return Ok(ScanBoxDecision {
                direction: Some(Side::Left),
                cycle: k,
                offset_m: off,
            });
        }
        if k > 0 && free_at(-off) {
            return Ok(ScanBoxDecision {
                direction: Some(Side::Right),
                cycle: k,
                offset_m: -off,
            });
        }
    }
    Ok(ScanBoxDecision {
        direction: None,
        cycle: cycles,
        offset_m: 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn grid() -> OccupancyGrid {
        // 8 m wide (80 cols), 4 m deep (40 rows), 0.1 m cells; x from -4 to 4
        OccupancyGrid::new(0.1, 80, 40).unwrap()
    }

    #[test]
    fn clear_image_goes_straight() {
        let d = scan_box_decide(&grid(), &ScanBoxParams::default()).unwrap();
        assert_eq!(
            d,
            ScanBoxDecision {
                direction: Some(Side::Left),
                cycle: 0,
                offset_m: 0.0
            }
        );
    }

    #[test]
    fn obstacle_left_of_centre_sends_the_box_right() {
        // occupied cell centres x in [-0.25, 0.95]: the centred box [-0.5, 0.5] is blocked.
        // right box at -k 0.2 is free once its left edge -0.2k + 0.5 < -0.25 (cells centred
        // at -0.25 are occupied; the box must exclude -0.25), i.e. k >= 4 (edge -0.3) while the
        // left box needs 0.2k - 0.5 > 1.0, k >= 8 -> RIGHT at cycle 4, offset -0.8
        let mut g = grid();
        g.fill_rect(-0.3, 1.0, 0.5, 1.0);
        let d = scan_box_decide(&g, &ScanBoxParams::default()).unwrap();
        assert_eq!(d.direction, Some(Side::Right));
        assert_eq!(d.cycle, 4);
        assert_relative_eq!(d.offset_m, -0.8, epsilon = 1e-9);
    }

    #[test]
    fn a_wall_beyond_half_the_range_means_no_path() {
        // wall from -3 to 3 m: max offset 2.5 m, the box edge reaches 3.0 at best -> none.
        // cycles = floor(2.5 / 0.2) + 1 = 13
        let mut g = grid();
        g.fill_rect(-3.0, 3.0, 1.0, 1.2);
        let d = scan_box_decide(&g, &ScanBoxParams::default()).unwrap();
        assert_eq!(d.direction, None);
        assert_eq!(d.cycle, 13);
    }

    #[test]
    fn cells_outside_the_image_count_as_occupied() {
        // a 1.2 m wide image: any offset > 0.1 pushes the 1 m box outside
        let mut g = OccupancyGrid::new(0.1, 12, 40).unwrap();
        g.set(5, 6, true);
        let d = scan_box_decide(&g, &ScanBoxParams::default()).unwrap();
        assert_eq!(d.direction, None);
        assert!(OccupancyGrid::new(0.0, 1, 1).is_err());
    }
}
