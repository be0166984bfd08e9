//! Time-indexed risk map (seed 002, "Risk maps"; threat filtering from "Pathfinding
//! algorithm"): for slices `t_k = t0 + k * dt` over the horizon, the probability that a
//! point lies within some obstacle's radius plus the safety buffer.
//!
//! Per obstacle, particles propagated with its stage's motion model (or, for an obstacle
//! on a recognized periodic tour, replayed from its earlier lap with a timing and position
//! spread, [`crate::periodic`]) are splatted with a
//! precomputed disc stencil of radius `radius + buffer` (a cell counts when its centre is
//! within that distance of the particle's cell centre); each particle carries `1/N` of the
//! mass. A NoFly obstacle is an analytic disc growing at the NoFly speed, evaluated at query
//! time instead of being gridded. Obstacles combine as `1 - prod(1 - p_i)`.
//!
//! Multi-resolution in time: uncertainty grows with the horizon, so late slices do not need
//! fine cells. Slices at most `fine_horizon_s` (default 15 s) after slice 0 use `cell_m`
//! (default 5 m) cells, slices up to `coarse_horizon_s` (default 40 s) use `cell_m *
//! coarse_factor` (default 10 m), later ones `cell_m * coarse_factor^2` (default 20 m). Every
//! slice's grid starts at `min_m` and covers the bounds; each stores its own cell size,
//! dimensions and offset, and splats with a stencil built for its own cell size (so an
//! obstacle's mass in a slice is that resolution's stencil area). `resolution(inf, inf, 1)`
//! gives `cell_m` everywhere.
//!
//! Data layout, chosen for the speed targets (incremental update of one obstacle <= 1 ms,
//! full rebuild of 10 <= 10 ms, >= 20 M queries/s at the default 5 m cells; the bench
//! `risk_map`, six runs on a shared 2-core machine under load ~3: medians 0.70-1.17 ms
//! (mostly 0.7-1.0), 7.7-12.8 ms (mostly 8-9) and 21-60 M/s (mostly 37-58), against
//! 2.5-3.0 ms, 24-34 ms and 16-56 M/s with 5 m cells in every slice):
//! - one dense `f32` grid per slice holding `q = prod(1 - p_i)`; a query is the slice's
//!   geometry (a small per-slice array of reciprocal cell size, width, height and offset)
//!   and one load per slice (`risk = 1 - q`, nearest cell); between two slice times the
//!   worse of the two bracketing slices answers (conservative in time: a fast obstacle
//!   moves more than the buffer in half a slice);
//! - per obstacle and slice, runs of consecutive cells with a `u16` particle count per
//!   cell (`p = count / particles`, exact, so mass is conserved exactly); `1 - p`
//!   (clamped to at least 1e-6) and its inverse come from tables, so an obstacle's
//!   contribution is removed and added by multiplications touching only its own cells: an
//!   observation of one obstacle redoes only that obstacle. The rounding drift of
//!   remove-then-add (f32, ~1e-7 per update) is wiped whenever the map is re-anchored or
//!   rebuilt (cells reset to exactly 1);
//! - splatting: particles are merged per cell, then each occupied cell adds its count at
//!   the start and subtracts it after the end of each stencil row in a grid-sized
//!   row-difference scratch (two operations per stamp and row); a prefix sum along each
//!   touched row span yields the counts, folds them into `q` and re-zeroes the scratch;
//! - per obstacle and slice a bounding box and peak probability, which answer
//!   `segment_risk_bound` without touching the grid.
//!
//! The cost of an update is dominated by the number of cells an obstacle covers over the
//! horizon (a Random-stage obstacle's cloud grows with time), and in particular by the
//! cache misses of the read-modify-write of `q`; a cell twice as large costs a quarter, which
//! is what the coarse late slices buy (the bench's scenario covers ~6x fewer cells than with
//! 5 m cells throughout).
//!
//! Threat filtering: an obstacle enters the map only if the intended path (ENU polyline)
//! passes within `radius + buffer + reach` of its position, where reach is the distance its
//! model can travel by the end of the horizon. An empty path disables the filter.
//!
//! The map is deterministic: obstacle `id`'s particles come from
//! `ChaCha8Rng::seed_from_u64(seed ^ fnv1a(id))`, so an incremental update and a full
//! rebuild give the same map.

use crate::field::RiskField;
use crate::motion::{MotionModel, Propagator};
use crate::stage::Stage;
use crate::track::Track;
use geom::dist_point_segment;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Largest observation gap a lap replay interpolates across, seconds.
const LAP_MAX_GAP_S: f64 = 5.0;
use std::collections::BTreeMap;

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

/// What one obstacle contributes to the map.
#[derive(Debug, Clone)]
pub struct ObstacleInput<'a> {
    /// Obstacle id (also seeds its particles).
    pub id: &'a str,
    /// Its motion model from its newest observation.
    pub model: &'a MotionModel,
    /// Its track (positions before the newest observation come from it).
    pub track: &'a Track,
    /// Sphere radius, metres.
    pub radius_m: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Disc {
    c: [f64; 2],
    r0_m: f64,
    growth_mps: f64,
    t_ref_s: f64,
}

#[derive(Debug, Clone, Default)]
struct Contribution {
    /// Not a threat: contributes nothing.
    filtered: bool,
    disc: Option<Disc>,
    /// Runs of consecutive cells; `counts[run.start..run.start + run.len]` are the numbers
    /// of particles whose stencil covers each cell (`p = count / particles`).
    runs: Vec<Run>,
    counts: Vec<u16>,
    /// `slice_start[k]..slice_start[k+1]` are slice k's runs.
    slice_start: Vec<u32>,
    /// Per slice `[x0, y0, x1, y1]` in metres (empty when x0 > x1), and peak probability.
    bbox_m: Vec<[f64; 4]>,
    max_p: Vec<f32>,
}

#[derive(Debug, Clone, Copy)]
struct Run {
    /// First cell (index within the slice).
    idx: u32,
    len: u32,
    /// Offset into `counts`.
    start: u32,
}

/// Where and at which resolution a slice is stored.
#[derive(Debug, Clone, Copy)]
struct SliceGeom {
    /// `1 / cell_m`.
    inv_cell: f64,
    cell_m: f64,
    /// Offset of the slice's first cell in `q`.
    off: usize,
    nx: usize,
    ny: usize,
    /// Resolution level (0 = `cell_m`).
    level: usize,
}

#[derive(Debug, Clone)]
struct Stencil {
    /// `(dy, half width)` rows.
    rows: Vec<(i32, i32)>,
    cells: usize,
}

/// A time-indexed risk map, updated incrementally per obstacle.
#[derive(Debug, Clone)]
pub struct RiskMap {
    cfg: RiskMapConfig,
    path: Vec<[f64; 2]>,
    t0_s: f64,
    /// Finest grid size.
    nx: usize,
    ny: usize,
    n_slices: usize,
    /// Per slice geometry (small, so a query's extra load stays in L1).
    geo: Vec<SliceGeom>,
    /// Geometry of the slice being splatted.
    cur: SliceGeom,
    inv_dt: f64,
    q: Vec<f32>,
    contrib: BTreeMap<String, Contribution>,
    discs: Vec<Disc>,
    /// Keyed by (radius in mm, resolution level).
    stencils: Vec<((u64, usize), Stencil)>,
    /// `1 - count / particles` (at least 1e-6) and its inverse, by count.
    omp_table: Vec<f32>,
    inv_table: Vec<f32>,
    /// Per finest-grid cell `(generation, merged weight)`: one cache line per particle.
    mark: Vec<(u32, u32)>,
    stamp_gen: u32,
    centres: Vec<u32>,
    /// Row-difference scratch of particle counts, `(nx + 1) * ny`, all zero between
    /// slices.
    diff: Vec<i32>,
    /// Touched span per grid row (empty = `(MAX, MIN)`), and the rows touched.
    row_span: Vec<(i32, i32)>,
    rows_touched: Vec<u32>,
    spare: Vec<Contribution>,
    stamps: Vec<(i32, i32, u32)>,
}

/// One slice of the map for rendering: row-major from the south-west corner, `data[iy *
/// width + ix]` is the risk of the cell whose south-west corner is `origin_m + (ix, iy) *
/// cell_m`.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SliceView {
    /// Time of the slice, seconds.
    pub t_s: f64,
    /// South-west corner, ENU metres.
    pub origin_m: [f64; 2],
    /// Cell size, metres.
    pub cell_m: f64,
    /// Cells east-west.
    pub width: usize,
    /// Cells north-south.
    pub height: usize,
    /// Risk per cell in `[0, 1]`.
    pub data: Vec<f32>,
}

fn fnv1a(s: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in s.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

fn dist_point_polyline(p: [f64; 2], path: &[[f64; 2]]) -> f64 {
    if path.len() == 1 {
        return (p[0] - path[0][0]).hypot(p[1] - path[0][1]);
    }
    path.windows(2)
        .map(|w| dist_point_segment(p, w[0], w[1]))
        .fold(f64::INFINITY, f64::min)
}

impl RiskMap {
    /// An empty map (no obstacle) over `cfg`'s grid, slices from `t0_s`, with the intended
    /// path used for threat filtering.
    ///
    /// # Errors
    /// [`RiskMapError`] for non-positive sizes or a grid over 2^31 cells.
    pub fn new(
        cfg: RiskMapConfig,
        intended_path: &[[f64; 2]],
        t0_s: f64,
    ) -> Result<Self, RiskMapError> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if !pos(cfg.cell_m) {
            return Err(RiskMapError::NotPositive("cell_m"));
        }
        if !pos(cfg.dt_s) {
            return Err(RiskMapError::NotPositive("dt_s"));
        }
        if !(cfg.horizon_s.is_finite() && cfg.horizon_s >= 0.0) {
            return Err(RiskMapError::NotPositive("horizon_s"));
        }
        if !pos(cfg.max_m[0] - cfg.min_m[0]) || !pos(cfg.max_m[1] - cfg.min_m[1]) {
            return Err(RiskMapError::NotPositive("max_m - min_m"));
        }
        if cfg.particles == 0 || cfg.particles > usize::from(u16::MAX) {
            return Err(RiskMapError::NotPositive("particles (1 ..= 65535)"));
        }
        if !(cfg.buffer_m.is_finite() && cfg.buffer_m >= 0.0) {
            return Err(RiskMapError::NotPositive("buffer_m"));
        }
        if cfg.fine_horizon_s.is_nan() || cfg.coarse_horizon_s.is_nan() {
            return Err(RiskMapError::NotPositive(
                "fine_horizon_s, coarse_horizon_s",
            ));
        }
        if !(1..=64).contains(&cfg.coarse_factor) {
            return Err(RiskMapError::NotPositive("coarse_factor (1 ..= 64)"));
        }
        let n_slices = (cfg.horizon_s / cfg.dt_s + 1e-9).floor() as u64 + 1;
        let dims = |level: u32| {
            let cell = cfg.cell_m * f64::from(cfg.coarse_factor.pow(level));
            (
                cell,
                ((cfg.max_m[0] - cfg.min_m[0]) / cell).ceil() as u64,
                ((cfg.max_m[1] - cfg.min_m[1]) / cell).ceil() as u64,
            )
        };
        let (_, nx, ny) = dims(0);
        if nx * ny >= 1 << 31 {
            return Err(RiskMapError::TooLarge(nx * ny * n_slices));
        }
        let mut geo = Vec::new();
        let mut total = 0u64;
        for k in 0..n_slices {
            let ahead_s = k as f64 * cfg.dt_s - 1e-9;
            let level = if ahead_s <= cfg.fine_horizon_s {
                0
            } else if ahead_s <= cfg.coarse_horizon_s {
                1
            } else {
                2
            };
            let (cell_m, lx, ly) = dims(level);
            geo.push(SliceGeom {
                inv_cell: 1.0 / cell_m,
                cell_m,
                off: total as usize,
                nx: lx as usize,
                ny: ly as usize,
                level: level as usize,
            });
            total += lx * ly;
            if total >= 1 << 31 {
                return Err(RiskMapError::TooLarge(total));
            }
        }
        let (nx, ny, n_slices) = (nx as usize, ny as usize, n_slices as usize);
        Ok(Self {
            cur: geo[0],
            geo,
            inv_dt: 1.0 / cfg.dt_s,
            path: intended_path.to_vec(),
            t0_s,
            nx,
            ny,
            n_slices,
            q: vec![1.0; total as usize],
            contrib: BTreeMap::new(),
            discs: Vec::new(),
            stencils: Vec::new(),
            omp_table: (0..=cfg.particles)
                .map(|c| (1.0 - c as f32 / cfg.particles as f32).max(1e-6))
                .collect(),
            inv_table: (0..=cfg.particles)
                .map(|c| 1.0 / (1.0 - c as f32 / cfg.particles as f32).max(1e-6))
                .collect(),
            mark: vec![(0, 0); nx * ny],
            stamp_gen: 0,
            centres: Vec::new(),
            diff: vec![0; (nx + 1) * ny],
            row_span: vec![(i32::MAX, i32::MIN); ny],
            rows_touched: Vec::new(),
            spare: Vec::new(),
            stamps: Vec::new(),
            cfg,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &RiskMapConfig {
        &self.cfg
    }
    /// The intended path used for threat filtering.
    pub fn intended_path(&self) -> &[[f64; 2]] {
        &self.path
    }
    /// Time of slice 0, seconds.
    pub fn t0_s(&self) -> f64 {
        self.t0_s
    }
    /// Horizon, seconds.
    pub fn horizon_s(&self) -> f64 {
        (self.n_slices - 1) as f64 * self.cfg.dt_s
    }
    /// Number of slices.
    pub fn slices(&self) -> usize {
        self.n_slices
    }
    /// Grid size `(width, height)` in cells of the finest slices (`cell_m`).
    pub fn grid_size(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }
    /// Ids of the obstacles in the map and whether each passed the threat filter.
    pub fn obstacles(&self) -> impl Iterator<Item = (&str, bool)> {
        self.contrib.iter().map(|(k, c)| (k.as_str(), !c.filtered))
    }
    /// Whether obstacle `id` is in the map and a threat to the intended path.
    pub fn is_threat(&self, id: &str) -> bool {
        self.contrib.get(id).is_some_and(|c| !c.filtered)
    }

    /// Slice index used for time `t_s` (nearest, clamped to the horizon).
    #[inline]
    pub fn slice_index(&self, t_s: f64) -> usize {
        let k = ((t_s - self.t0_s) * self.inv_dt + 0.5).floor();
        if k <= 0.0 {
            0
        } else {
            (k as usize).min(self.n_slices - 1)
        }
    }

    /// Cell size of slice `k`, metres (`cell_m` times a power of `coarse_factor`, see
    /// [`RiskMapConfig::resolution`]); the last slice's for `k` beyond the horizon.
    pub fn slice_cell_m(&self, k: usize) -> f64 {
        self.geo[k.min(self.n_slices - 1)].cell_m
    }

    fn slice_time(&self, k: usize) -> f64 {
        self.t0_s + k as f64 * self.cfg.dt_s
    }

    /// Mass of obstacle `id` in slice `k`: the sum of its probabilities times the cell
    /// area, square metres (the area of its stencil when wholly inside the grid). `None`
    /// for an unknown, filtered or NoFly obstacle.
    pub fn obstacle_mass_m2(&self, id: &str, k: usize) -> Option<f64> {
        let c = self.contrib.get(id)?;
        if c.filtered || c.disc.is_some() || k >= self.n_slices {
            return None;
        }
        let r = c.slice_start[k] as usize..c.slice_start[k + 1] as usize;
        let n: u64 = c.runs[r]
            .iter()
            .flat_map(|run| &c.counts[run.start as usize..(run.start + run.len) as usize])
            .map(|&x| u64::from(x))
            .sum();
        let cm = self.geo[k].cell_m;
        Some(n as f64 / self.cfg.particles as f64 * cm * cm)
    }

    /// Number of grid cells (over all slices) obstacle `id` contributes to: the work an
    /// incremental update of it costs.
    pub fn obstacle_cells(&self, id: &str) -> Option<usize> {
        self.contrib
            .get(id)
            .map(|c| c.counts.iter().filter(|&&x| x > 0).count())
    }

    /// Area of the splat stencil of a sphere of `radius_m` (plus the buffer) at the finest
    /// resolution (`cell_m`), square metres.
    pub fn stencil_area_m2(&mut self, radius_m: f64) -> f64 {
        self.slice_stencil_area_m2(radius_m, 0)
    }

    /// Area of the splat stencil of a sphere of `radius_m` (plus the buffer) in slice `k`
    /// (at that slice's resolution), square metres: an obstacle's mass in every slice.
    pub fn slice_stencil_area_m2(&mut self, radius_m: f64, k: usize) -> f64 {
        let g = self.geo[k.min(self.n_slices - 1)];
        let i = self.stencil(radius_m + self.cfg.buffer_m, g);
        self.stencils[i].1.cells as f64 * g.cell_m * g.cell_m
    }

    fn stencil(&mut self, r_m: f64, g: SliceGeom) -> usize {
        let key = ((r_m * 1000.0).round() as u64, g.level);
        if let Some(i) = self.stencils.iter().position(|(k, _)| *k == key) {
            return i;
        }
        let rc = r_m / g.cell_m;
        let n = rc.floor() as i32;
        let mut rows = Vec::new();
        let mut cells = 0;
        for dy in -n..=n {
            let rem = rc * rc - f64::from(dy * dy);
            if rem < 0.0 {
                continue;
            }
            let hw = rem.sqrt().floor() as i32;
            rows.push((dy, hw));
            cells += (2 * hw + 1) as usize;
        }
        self.stencils.push((key, Stencil { rows, cells }));
        self.stencils.len() - 1
    }

    /// Removes every obstacle and rebuilds the map from `obstacles`.
    pub fn rebuild<'a>(&mut self, obstacles: impl IntoIterator<Item = ObstacleInput<'a>>) {
        self.clear_all();
        for o in obstacles {
            self.update_obstacle(&o);
        }
    }

    /// Removes every obstacle and moves the map to a new slice-0 time and intended path,
    /// keeping its allocation (re-anchoring costs only the removal of the old
    /// contributions).
    pub fn reset(&mut self, intended_path: &[[f64; 2]], t0_s: f64) {
        self.clear_all();
        self.path.clear();
        self.path.extend_from_slice(intended_path);
        self.t0_s = t0_s;
    }

    /// Every contribution removed: the cells they touched are set back to exactly 1, which
    /// also wipes the rounding drift of incremental updates.
    fn clear_all(&mut self) {
        for c in self.contrib.values() {
            for k in 0..self.n_slices.min(c.slice_start.len().saturating_sub(1)) {
                let base = self.geo[k].off;
                for run in &c.runs[c.slice_start[k] as usize..c.slice_start[k + 1] as usize] {
                    let a = base + run.idx as usize;
                    self.q[a..a + run.len as usize].fill(1.0);
                }
            }
        }
        // Keep the allocations for the next rebuild.
        let old = std::mem::take(&mut self.contrib);
        self.spare.extend(old.into_values().map(|mut c| {
            c.runs.clear();
            c.counts.clear();
            c.slice_start.clear();
            c
        }));
        self.discs.clear();
    }

    /// Removes obstacle `id`'s contribution.
    pub fn remove_obstacle(&mut self, id: &str) {
        if let Some(c) = self.contrib.remove(id) {
            self.subtract(&c);
            self.refresh_discs();
        }
    }

    fn subtract(&mut self, c: &Contribution) {
        for k in 0..self.n_slices.min(c.slice_start.len().saturating_sub(1)) {
            let base = self.geo[k].off;
            let r = c.slice_start[k] as usize..c.slice_start[k + 1] as usize;
            for run in &c.runs[r] {
                let a = base + run.idx as usize;
                let counts = &c.counts[run.start as usize..(run.start + run.len) as usize];
                for (q, &n) in self.q[a..a + run.len as usize].iter_mut().zip(counts) {
                    *q *= self.inv_table[usize::from(n)];
                    // Snap the rounding drift of multiply-then-divide back to exactly 1.
                    if *q > 1.0 - 1e-6 {
                        *q = 1.0;
                    }
                }
            }
        }
    }

    fn refresh_discs(&mut self) {
        self.discs = self
            .contrib
            .values()
            .filter(|c| !c.filtered)
            .filter_map(|c| c.disc)
            .collect();
    }

    /// Replaces obstacle `o.id`'s contribution with one computed from its current model:
    /// only its own cells are touched.
    pub fn update_obstacle(&mut self, o: &ObstacleInput<'_>) {
        let mut c = self
            .contrib
            .remove(o.id)
            .or_else(|| self.spare.pop())
            .unwrap_or_default();
        self.subtract(&c);
        c.filtered = false;
        c.disc = None;
        c.runs.clear();
        c.counts.clear();
        c.slice_start.clear();
        c.bbox_m.clear();
        c.max_p.clear();
        let r_m = o.radius_m + self.cfg.buffer_m;
        let t_end = self.t0_s + self.horizon_s();
        if !self.path.is_empty() {
            let reach = o.model.reach_m(t_end - o.model.t_s);
            if dist_point_polyline(o.model.position_m, &self.path) > r_m + reach {
                c.filtered = true;
            }
        }
        if !c.filtered && o.model.stage == Stage::NoFly {
            c.disc = Some(Disc {
                c: o.model.position_m,
                r0_m: r_m,
                growth_mps: o.model.nofly_speed_mps,
                t_ref_s: o.model.t_s,
            });
        } else if !c.filtered {
            self.splat_obstacle(o, r_m, &mut c);
        }
        self.contrib.insert(o.id.to_owned(), c);
        self.refresh_discs();
    }

    fn splat_obstacle(&mut self, o: &ObstacleInput<'_>, r_m: f64, c: &mut Contribution) {
        // Stencil per resolution level (at most three).
        let mut si = [usize::MAX; 3];
        for k in 0..self.n_slices {
            let g = self.geo[k];
            if si[g.level] == usize::MAX {
                si[g.level] = self.stencil(r_m, g);
            }
        }
        let n = self.cfg.particles;
        let mut rng = ChaCha8Rng::seed_from_u64(self.cfg.seed ^ fnv1a(o.id));
        let mut prop = Propagator::new(o.model, n, &mut rng);
        // A periodic tour's particles: a fixed timing and position deviate each, scaled by
        // the lap's spread at each slice (crate::periodic).
        let lap_z: Vec<[f64; 3]> = if o.model.lap.is_some() {
            (0..n)
                .map(|_| std::array::from_fn(|_| StandardNormal.sample(&mut rng)))
                .collect()
        } else {
            Vec::new()
        };
        let all = n as u32;
        c.slice_start.push(0);
        for k in 0..self.n_slices {
            let tk = self.slice_time(k);
            self.cur = self.geo[k];
            self.begin_slice();
            if tk <= o.model.t_s {
                let p = o
                    .track
                    .position_at(tk, f64::INFINITY)
                    .unwrap_or(o.model.position_m);
                self.add_particle(p, all);
            } else if o.model.speed_mps <= 0.0 {
                self.add_particle(o.model.position_m, all);
            } else if let Some(replay) = o.model.lap.and_then(|lap| {
                let s = tk - o.model.t_s;
                let base = lap.position(o.track, s, LAP_MAX_GAP_S)?;
                let ahead = lap
                    .position(o.track, s + 0.5, LAP_MAX_GAP_S)
                    .unwrap_or(base);
                let behind = lap
                    .position(o.track, s - 0.5, LAP_MAX_GAP_S)
                    .unwrap_or(base);
                Some((base, [ahead[0] - behind[0], ahead[1] - behind[1]], lap, s))
            }) {
                let (base, vel, lap, s) = replay;
                let (sig, jit) = (lap.sigma_m(s), lap.jitter_s(s));
                for z in &lap_z {
                    self.add_particle(
                        [
                            base[0] + vel[0] * z[0] * jit + z[1] * sig,
                            base[1] + vel[1] * z[0] * jit + z[2] * sig,
                        ],
                        1,
                    );
                }
            } else {
                prop.advance_to(tk, &mut rng);
                for i in 0..n {
                    self.add_particle([prop.x[i], prop.y[i]], 1);
                }
            }
            self.finish_slice(si[self.cur.level], c);
        }
    }

    fn begin_slice(&mut self) {
        self.stamp_gen = self.stamp_gen.wrapping_add(1);
        if self.stamp_gen == 0 {
            self.mark.fill((0, 0));
            self.stamp_gen = 1;
        }
        self.centres.clear();
        self.stamps.clear();
    }

    /// Merges a particle into its cell; a particle outside the grid is stamped on its own
    /// (its stencil may still reach the grid).
    fn add_particle(&mut self, p: [f64; 2], w: u32) {
        let g = &self.cur;
        let fx = (p[0] - self.cfg.min_m[0]) * g.inv_cell;
        let fy = (p[1] - self.cfg.min_m[1]) * g.inv_cell;
        // Inside the grid the truncating casts are the floor (no libm call on this path).
        if fx >= 0.0 && fy >= 0.0 && fx < g.nx as f64 && fy < g.ny as f64 {
            let j = fy as usize * g.nx + fx as usize;
            let m = &mut self.mark[j];
            if m.0 != self.stamp_gen {
                *m = (self.stamp_gen, w);
                self.centres.push(j as u32);
            } else {
                m.1 += w;
            }
        } else {
            let (fx, fy) = (fx.floor(), fy.floor());
            self.stamps
                .push((fx.clamp(-1e8, 1e8) as i32, fy.clamp(-1e8, 1e8) as i32, w));
        }
    }

    /// Splats the slice's merged centres into a dense buffer over their bounding box
    /// (contiguous row additions), then keeps the non-zero cells as the slice's entries.
    #[inline(never)]
    fn finish_slice(&mut self, si: usize, c: &mut Contribution) {
        let g = self.cur;
        let nx = g.nx as i32;
        let ny = g.ny as i32;
        for &j in &self.centres {
            let j = j as usize;
            self.stamps
                .push(((j % g.nx) as i32, (j / g.nx) as i32, self.mark[j].1));
        }
        let stencil = &self.stencils[si].1;
        let rc = stencil
            .rows
            .iter()
            .map(|r| r.0.abs().max(r.1))
            .max()
            .unwrap_or(0);
        let (mut bx0, mut by0, mut bx1, mut by1) = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
        for &(cx, cy, _) in &self.stamps {
            bx0 = bx0.min(cx);
            by0 = by0.min(cy);
            bx1 = bx1.max(cx);
            by1 = by1.max(cy);
        }
        let (bx0, by0) = (
            (bx0.saturating_sub(rc)).max(0),
            (by0.saturating_sub(rc)).max(0),
        );
        let (bx1, by1) = (
            (bx1.saturating_add(rc)).min(nx - 1),
            (by1.saturating_add(rc)).min(ny - 1),
        );
        let mut bb = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut max_p: f32 = 0.0;
        if bx0 <= bx1 && by0 <= by1 && !self.stamps.is_empty() {
            // Row differences into the grid-sized scratch (kept all zero between slices):
            // each stencil row adds +w at its first cell and -w just after its last; a
            // prefix sum along the row's touched span then gives the splat, and the scan
            // zeroes the scratch behind it. Two operations per stamp and row, whatever the
            // stencil's width, and no clearing of untouched cells.
            let stride = g.nx + 1;
            self.rows_touched.clear();
            for &(cx, cy, w) in &self.stamps {
                for &(dy, hw) in &stencil.rows {
                    let y = cy + dy;
                    if y < by0 || y > by1 {
                        continue;
                    }
                    let x0 = (cx - hw).max(bx0);
                    let x1 = (cx + hw).min(bx1);
                    if x0 > x1 {
                        continue;
                    }
                    let row = y as usize * stride;
                    self.diff[row + x0 as usize] += w as i32;
                    self.diff[row + x1 as usize + 1] -= w as i32;
                    let span = &mut self.row_span[y as usize];
                    if span.0 > span.1 {
                        self.rows_touched.push(y as u32);
                    }
                    span.0 = span.0.min(x0);
                    span.1 = span.1.max(x1);
                }
            }
            self.rows_touched.sort_unstable();
            let (mut ix0, mut iy0, mut ix1, mut iy1) = (usize::MAX, usize::MAX, 0, 0);
            let qbase = g.off;
            let mut max_count = 0u32;
            for &gy in &self.rows_touched {
                let gy = gy as usize;
                let (lo, hi) = std::mem::replace(&mut self.row_span[gy], (i32::MAX, i32::MIN));
                let (lo, hi) = (lo as usize, hi as usize);
                let row = &mut self.diff[gy * stride + lo..=gy * stride + hi + 1];
                let gbase = gy * g.nx + lo;
                let (last, body) = row.split_last_mut().expect("span is not empty");
                *last = 0;
                let mut acc = 0i32;
                // Open run: (first cell, counts offset); a gap of GAP zero cells closes it.
                const GAP: usize = 8;
                let mut open: Option<(usize, usize)> = None;
                let mut zeros = 0usize;
                let mut row_first = usize::MAX;
                let mut row_last = 0usize;
                for (xx, d) in body.iter_mut().enumerate() {
                    acc += *d;
                    *d = 0;
                    if acc > 0 {
                        let n = acc as u32;
                        max_count = max_count.max(n);
                        if open.is_none() {
                            open = Some((xx, c.counts.len()));
                        } else {
                            // Keep the short gap inside the run (zero counts).
                            c.counts.extend(std::iter::repeat_n(0, zeros));
                        }
                        zeros = 0;
                        c.counts.push(n as u16);
                        // Fold the contribution into the combined grid in the same pass.
                        self.q[qbase + gbase + xx] *= self.omp_table[n as usize];
                        row_first = row_first.min(xx);
                        row_last = xx;
                    } else if let Some((x_start, start)) = open {
                        zeros += 1;
                        if zeros >= GAP {
                            let len = c.counts.len() - start;
                            c.runs.push(Run {
                                idx: (gbase + x_start) as u32,
                                len: len as u32,
                                start: start as u32,
                            });
                            open = None;
                            zeros = 0;
                        }
                    }
                }
                if let Some((x_start, start)) = open {
                    let len = c.counts.len() - start;
                    c.runs.push(Run {
                        idx: (gbase + x_start) as u32,
                        len: len as u32,
                        start: start as u32,
                    });
                }
                if row_first != usize::MAX {
                    ix0 = ix0.min(lo + row_first);
                    ix1 = ix1.max(lo + row_last);
                    iy0 = iy0.min(gy);
                    iy1 = iy1.max(gy);
                }
            }
            max_p = (max_count as f32 / self.cfg.particles as f32).min(1.0);
            if ix0 != usize::MAX {
                let cm = g.cell_m;
                bb = [
                    self.cfg.min_m[0] + ix0 as f64 * cm,
                    self.cfg.min_m[1] + iy0 as f64 * cm,
                    self.cfg.min_m[0] + (ix1 + 1) as f64 * cm,
                    self.cfg.min_m[1] + (iy1 + 1) as f64 * cm,
                ];
            }
        }
        c.slice_start.push(c.runs.len() as u32);
        c.bbox_m.push(bb);
        c.max_p.push(max_p);
    }

    #[inline]
    fn disc_risk(&self, p_m: [f64; 2], k: usize) -> f64 {
        let tk = self.slice_time(k);
        for d in &self.discs {
            let r = d.r0_m + d.growth_mps * (tk - d.t_ref_s).max(0.0);
            let (dx, dy) = (p_m[0] - d.c[0], p_m[1] - d.c[1]);
            if dx * dx + dy * dy <= r * r {
                return 1.0;
            }
        }
        0.0
    }

    /// The slice nearest `t_s`, for rendering.
    pub fn slice(&self, t_s: f64) -> SliceView {
        let k = self.slice_index(t_s);
        let g = self.geo[k];
        let mut data: Vec<f32> = self.q[g.off..g.off + g.nx * g.ny]
            .iter()
            .map(|&q| (1.0 - q).clamp(0.0, 1.0))
            .collect();
        if !self.discs.is_empty() {
            let cm = g.cell_m;
            for iy in 0..g.ny {
                for ix in 0..g.nx {
                    let p = [
                        self.cfg.min_m[0] + (ix as f64 + 0.5) * cm,
                        self.cfg.min_m[1] + (iy as f64 + 0.5) * cm,
                    ];
                    if self.disc_risk(p, k) > 0.0 {
                        data[iy * g.nx + ix] = 1.0;
                    }
                }
            }
        }
        SliceView {
            t_s: self.slice_time(k),
            origin_m: self.cfg.min_m,
            cell_m: g.cell_m,
            width: g.nx,
            height: g.ny,
            data,
        }
    }
}

impl RiskMap {
    /// Risk of slice `k` at `p_m` (grid and NoFly discs).
    #[inline]
    fn slice_risk(&self, p_m: [f64; 2], k: usize) -> f64 {
        let g = &self.geo[k];
        let fx = (p_m[0] - self.cfg.min_m[0]) * g.inv_cell;
        let fy = (p_m[1] - self.cfg.min_m[1]) * g.inv_cell;
        let mut r = 0.0;
        if fx >= 0.0 && fy >= 0.0 {
            let (ix, iy) = (fx as usize, fy as usize);
            if ix < g.nx && iy < g.ny {
                r = 1.0 - f64::from(self.q[g.off + iy * g.nx + ix]);
            }
        }
        if !self.discs.is_empty() && r < 1.0 {
            r = r.max(self.disc_risk(p_m, k));
        }
        r
    }

    /// The slices bracketing `t_s`: `(k, k)` at a slice time (or outside the horizon),
    /// else `(k, k + 1)` with `t_k < t_s < t_(k+1)`.
    #[inline]
    fn bracket(&self, t_s: f64) -> (usize, usize) {
        let f = (t_s - self.t0_s) * self.inv_dt;
        if f <= 0.0 {
            return (0, 0);
        }
        let k = f.floor();
        let last = self.n_slices - 1;
        let k0 = (k as usize).min(last);
        if f - k < 1e-6 || k0 == last {
            (k0, k0)
        } else {
            (k0, k0 + 1)
        }
    }
}

impl RiskField for RiskMap {
    /// The worse of the two slices bracketing `t_s` (a 40 kt obstacle moves 10 m in half
    /// a 1 s slice, more than the buffer: reading the nearest slice alone could miss it).
    #[inline]
    fn risk(&self, p_m: [f64; 2], t_s: f64) -> f64 {
        let (k0, k1) = self.bracket(t_s);
        let mut r = self.slice_risk(p_m, k0);
        if k1 != k0 && r < 1.0 {
            r = r.max(self.slice_risk(p_m, k1));
        }
        r.clamp(0.0, 1.0)
    }

    /// Conservative: `1 - prod(1 - peak_i)` over every obstacle whose slice bounding box
    /// meets the segment's bounding box in a slice the segment's times map to; 1 if the
    /// segment comes within a NoFly disc.
    fn segment_risk_bound(&self, a_m: [f64; 2], b_m: [f64; 2], t0_s: f64, t1_s: f64) -> f64 {
        let (ka, kb) = (
            self.bracket(t0_s.min(t1_s)).0,
            self.bracket(t0_s.max(t1_s)).1,
        );
        let (k0, k1) = (ka.min(kb), ka.max(kb));
        let sb = [
            a_m[0].min(b_m[0]),
            a_m[1].min(b_m[1]),
            a_m[0].max(b_m[0]),
            a_m[1].max(b_m[1]),
        ];
        for d in &self.discs {
            let r = d.r0_m + d.growth_mps * (self.slice_time(k1) - d.t_ref_s).max(0.0);
            if dist_point_segment(d.c, a_m, b_m) <= r {
                return 1.0;
            }
        }
        let mut keep = 1.0f64;
        for c in self.contrib.values() {
            if c.filtered || c.disc.is_some() {
                continue;
            }
            let mut peak: f32 = 0.0;
            for k in k0..=k1 {
                let bb = c.bbox_m[k];
                if bb[0] <= sb[2] && sb[0] <= bb[2] && bb[1] <= sb[3] && sb[1] <= bb[3] {
                    peak = peak.max(c.max_p[k]);
                }
            }
            keep *= 1.0 - f64::from(peak);
        }
        (1.0 - keep).clamp(0.0, 1.0)
    }
}
