//! The Offset Algorithm's parameters (with their documented defaults and builder) and its
//! input errors.

#[cfg(doc)]
use super::{OffsetDecision, OffsetWorkspace};

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
    setters! {
        /// Set the scan radii (metres, any order).
        with_scan_radii_m(scan_radii_m: Vec<f64>);
        /// Set the threshold `T`.
        with_threshold(threshold: f64);
        /// Set the window size `N` (beams).
        with_window(window: usize);
        /// Set the field of view (degrees).
        with_fov_deg(fov_deg: f64);
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
