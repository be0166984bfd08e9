//! Risk-map parameters ([`RiskMapConfig`], a builder with documented defaults) and the
//! error for invalid ones.

/// Risk-map parameters, with documented defaults.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct RiskMapConfig {
    /// South-west corner of the grid, ENU metres. Default `[-1000, -1000]`.
    pub min_m: [f64; 2],
    /// North-east corner of the grid, ENU metres. Default `[1000, 1000]`.
    pub max_m: [f64; 2],
    /// Cell size of the finest slices, metres. Default 5 (about half the smallest 30 ft
    /// sphere radius).
    pub cell_m: f64,
    /// Slices at most this long after slice 0 use `cell_m` cells, seconds. Default 15.
    pub fine_horizon_s: f64,
    /// Later slices at most this long after slice 0 use `cell_m * coarse_factor` cells;
    /// slices beyond it `cell_m * coarse_factor^2`, seconds. Default 40.
    pub coarse_horizon_s: f64,
    /// Ratio between the cell sizes of consecutive resolutions (1 = `cell_m` everywhere).
    /// Default 2: 5 m cells up to 15 s, 10 m up to 40 s, 20 m beyond.
    pub coarse_factor: u32,
    /// Time between slices, seconds. Default 1.
    pub dt_s: f64,
    /// Horizon, seconds: slices at `0, dt, .., horizon`. Default 60.
    pub horizon_s: f64,
    /// Safety buffer added to every obstacle radius, metres. Default 5.
    pub buffer_m: f64,
    /// Particles per obstacle. Default 256.
    pub particles: usize,
    /// Seed of the particles. Default 0.
    pub seed: u64,
    /// How far after slice 0 a NoFly obstacle's disc counts, seconds; `None`: over the
    /// whole horizon. Default `None` (measured and not kept as the default; README,
    /// "Young tracks' discs within the near window only"). A NoFly track is one too young
    /// to characterize (at 2 Hz it leaves the stage about 2-3 s after it is first seen);
    /// its disc grows at the NoFly speed (25.7 m/s by default) and within 30 s covers most
    /// of a competition field, so the first plans of a flight send the route round it.
    /// `Some(10.0)` (the planner's near window, `planner::VerifyParams::near_s`) keeps the
    /// disc a wall within the window and counts nothing beyond it.
    #[cfg_attr(feature = "serde", serde(default))]
    pub nofly_horizon_s: Option<f64>,
    /// Splat each particle from the centre of its third of a cell (nine stencils a radius)
    /// instead of from its cell's centre, which is up to half a cell off on each axis (7 m
    /// with 10 m cells). Default false (measured and not kept as the default; README,
    /// "Splatted from a third of a cell"): flights 2-3 s shorter on the judges' feed, but
    /// more sphere hits over the same seeds.
    pub subcell_splat: bool,
    /// Keep the finest slices (those up to `fine_horizon_s`) out of the shared grid: a read
    /// there is the product over the obstacles whose slice box holds the point, each one's
    /// count at the cell looked up in its own runs. The fine slices then cost memory only
    /// where obstacles are, not a grid of the whole field each, so they can use small cells
    /// (the server's 5 m up to 15 s); a read costs a box test per obstacle instead of one
    /// load. Default false.
    #[cfg_attr(feature = "serde", serde(default))]
    pub sparse_fine: bool,
}

impl Default for RiskMapConfig {
    fn default() -> Self {
        Self {
            min_m: [-1000.0, -1000.0],
            max_m: [1000.0, 1000.0],
            cell_m: 5.0,
            fine_horizon_s: 15.0,
            coarse_horizon_s: 40.0,
            coarse_factor: 2,
            dt_s: 1.0,
            horizon_s: 60.0,
            buffer_m: 5.0,
            particles: 256,
            seed: 0,
            nofly_horizon_s: None,
            subcell_splat: false,
            sparse_fine: false,
        }
    }
}

impl RiskMapConfig {
    /// Sets the grid bounds.
    pub fn bounds(mut self, min_m: [f64; 2], max_m: [f64; 2]) -> Self {
        self.min_m = min_m;
        self.max_m = max_m;
        self
    }
    /// Splats particles from their third of a cell ([`RiskMapConfig::subcell_splat`]).
    pub fn subcell_splat(mut self, on: bool) -> Self {
        self.subcell_splat = on;
        self
    }
    /// Keeps the finest slices out of the shared grid ([`RiskMapConfig::sparse_fine`]).
    pub fn sparse_fine(mut self, on: bool) -> Self {
        self.sparse_fine = on;
        self
    }
    /// Sets the cell size.
    pub fn cell_m(mut self, cell_m: f64) -> Self {
        self.cell_m = cell_m;
        self
    }
    /// Sets the resolution schedule: `cell_m` cells up to `fine_horizon_s` after slice 0,
    /// `cell_m * coarse_factor` up to `coarse_horizon_s`, `cell_m * coarse_factor^2`
    /// beyond. `resolution(f64::INFINITY, f64::INFINITY, 1)` keeps `cell_m` everywhere.
    pub fn resolution(
        mut self,
        fine_horizon_s: f64,
        coarse_horizon_s: f64,
        coarse_factor: u32,
    ) -> Self {
        self.fine_horizon_s = fine_horizon_s;
        self.coarse_horizon_s = coarse_horizon_s;
        self.coarse_factor = coarse_factor;
        self
    }
    /// Sets the slice spacing and horizon.
    pub fn time(mut self, dt_s: f64, horizon_s: f64) -> Self {
        self.dt_s = dt_s;
        self.horizon_s = horizon_s;
        self
    }
    /// Sets the safety buffer.
    pub fn buffer_m(mut self, buffer_m: f64) -> Self {
        self.buffer_m = buffer_m;
        self
    }
    /// Sets the particle count.
    pub fn particles(mut self, n: usize) -> Self {
        self.particles = n;
        self
    }
    /// Sets the seed.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }
    /// Sets how far after slice 0 a NoFly disc counts (`None`: the whole horizon).
    pub fn nofly_horizon_s(mut self, nofly_horizon_s: Option<f64>) -> Self {
        self.nofly_horizon_s = nofly_horizon_s;
        self
    }
}

/// Invalid risk-map parameters.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RiskMapError {
    /// A size parameter is not positive and finite; fix the named field.
    #[error("{0} must be positive and finite")]
    NotPositive(&'static str),
    /// The grid would be larger than 2^31 cells in total; use a larger cell or smaller area.
    #[error("grid too large: {0} cells")]
    TooLarge(u64),
}
