//! Time-indexed risk map (seed 002, "Risk maps"; threat filtering from "Pathfinding
//! algorithm"): for slices `t_k = t0 + k * dt` over the horizon, the probability that a
//! point lies within some obstacle's radius plus the safety buffer.
//!
//! Per obstacle, particles propagated with its stage's motion model (or, for an obstacle
//! on a recognized periodic tour, replayed from its earlier lap with a timing and position
//! spread, [`crate::periodic`]; or, with enough history, flying stretches of its own past,
//! [`crate::replay`]) are splatted with a
//! precomputed disc stencil of radius `radius + buffer` (a cell counts when its centre is
//! within that distance of the particle's cell centre, or with
//! [`RiskMapConfig::subcell_splat`] of the centre of the particle's third of a cell: nine
//! stencils a radius, one per sub-cell position); each particle carries `1/N` of the
//! mass. A NoFly obstacle is an analytic disc growing at the NoFly speed, evaluated at query
//! time instead of being gridded (in the slices within [`RiskMapConfig::nofly_horizon_s`]
//! of slice 0 only, when that is set). Obstacles combine as `1 - prod(1 - p_i)`.
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
//! full rebuild of 10 <= 10 ms, >= 20 M queries/s at the default 5 m cells; measured by
//! `cargo bench -p predictor --bench risk_map`, results in `predictor/benches/README.md`):
//! - one dense `f32` grid per slice holding `q = prod(1 - p_i)`; a query is the slice's
//!   geometry (a small per-slice array of reciprocal cell size, width, height and offset)
//!   and one load per slice (`risk = 1 - q`, nearest cell); between two slice times the
//!   worse of the two bracketing slices answers (conservative in time: a fast obstacle
//!   moves more than the buffer in half a slice). With [`RiskMapConfig::sparse_fine`] the
//!   finest slices have no dense grid: a read there is `1 - prod(1 - p_i)` over the
//!   obstacles whose slice bounding box (or NoFly disc) holds the point, each count found
//!   by a binary search in the obstacle's runs, so small fine cells cost memory only where
//!   obstacles are (the server's 5 m cells up to 15 s); and between two such slices each
//!   obstacle is read where its cloud is at the time asked: in both slices at the point
//!   moved back (forward) by the part of its particles' mean move between the slices that
//!   the time has (still) to go, the larger count kept. A cloud moving as a whole is then
//!   read where it is, not over both slices' places (10 m ahead and behind for a 20 m/s
//!   obstacle between half-second slices);
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
//! - per obstacle and slice a bounding box, peak probability and particle mean, which
//!   answer `segment_risk_bound` without touching the grid (between two sparse slices each
//!   box swept along the mean's move, where a read between them may look).
//!
//! The cost of an update is dominated by the number of cells an obstacle covers over the
//! horizon (a Random-stage obstacle's cloud grows with time), and in particular by the
//! cache misses of the read-modify-write of `q`; a cell twice as large costs a quarter, which
//! is what the coarse late slices buy.
//!
//! Threat filtering: an obstacle enters the map only if the intended path (ENU polyline)
//! passes within `radius + buffer + reach` of its position, where reach is the distance its
//! model can travel by the end of the horizon. An empty path disables the filter.
//!
//! The map is deterministic: obstacle `id`'s particles come from
//! `ChaCha8Rng::seed_from_u64(seed ^ fnv1a(id))`, so an incremental update and a full
//! rebuild give the same map.
//!
//! Files: `config.rs` the parameters, `splat.rs` the writes (an obstacle's particles into
//! runs of counts), `query.rs` the reads (`risk`, slices, segment bounds), `banded.rs` the
//! reads for one altitude band of the aircraft ([`AltitudeView`]).

mod banded;
mod config;
mod query;
mod splat;

pub use banded::AltitudeView;

pub use config::{RiskMapConfig, RiskMapError};

use crate::motion::MotionModel;
use crate::stage::Stage;
use crate::track::Track;
use geom::dist_point_segment;
use std::collections::BTreeMap;

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
    /// Its frames, for a model that replays its own past ([`crate::replay`]).
    pub manoeuvres: Option<&'a crate::replay::Manoeuvres>,
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
    /// Per slice the particles' mean position, metres: a read between two sparse slices
    /// follows the cloud by the mean's move between them ([`RiskMapConfig::sparse_fine`]).
    centre_m: Vec<[f64; 2]>,
    /// The speed of the motion model it was built from, m/s
    /// ([`AltitudeView::fast_weight`]).
    speed_mps: f64,
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
    /// Not in the shared grid `q` ([`RiskMapConfig::sparse_fine`]): read from the
    /// obstacles' runs (`off` unused).
    sparse: bool,
}

#[derive(Debug, Clone)]
struct Stencil {
    /// `(dy, first dx, last dx)` rows, relative to the particle's cell.
    rows: Vec<(i32, i32, i32)>,
    cells: usize,
    /// Largest `|dy|` or `|dx|` of a row.
    extent: i32,
}

/// Sub-cell positions per axis a particle is splatted from with
/// [`RiskMapConfig::subcell_splat`]: its stencil is the cells whose centres lie within
/// `radius + buffer` of the centre of its third of a cell, not of its cell (odd, so the
/// middle position, the only one without it, is the cell centre).
pub(crate) const SUB: usize = 3;
/// Sub-cell positions per cell.
pub(crate) const SUB2: usize = SUB * SUB;

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
    /// Keyed by (radius in mm, resolution level, sub-cell position).
    stencils: Vec<((u64, usize, usize), Stencil)>,
    /// `1 - count / particles` (at least 1e-6) and its inverse, by count.
    omp_table: Vec<f32>,
    inv_table: Vec<f32>,
    /// Per finest-grid cell `(generation, index into centres)`: one cache line per particle.
    mark: Vec<(u32, u32)>,
    stamp_gen: u32,
    /// The slice's occupied cells and their merged weight per sub-cell position.
    centres: Vec<(u32, [u32; SUB2])>,
    /// The slice's particles' weighted sum of positions and total weight.
    mean_acc: [f64; 3],
    /// Row-difference scratch of particle counts, `(nx + 1) * ny`, all zero between
    /// slices.
    diff: Vec<i32>,
    /// Touched span per grid row (empty = `(MAX, MIN)`), and the rows touched.
    row_span: Vec<(i32, i32)>,
    rows_touched: Vec<u32>,
    spare: Vec<Contribution>,
    /// `(cell x, cell y, weight, sub-cell position)` to splat.
    stamps: Vec<(i32, i32, u32, u32)>,
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

/// One obstacle's part of a map, taken out of it ([`RiskMap::take_layer`]) to be put into
/// another map of the same frame ([`RiskMap::put_layer`]): how one map is built on several
/// threads, each computing some obstacles on a map of its own. The cells are those of a
/// one-thread build, bit for bit, when the layers are put in the order that build would
/// have added the obstacles (an obstacle's part depends only on its input and the frame:
/// its particles are seeded by its id).
#[derive(Debug, Clone)]
pub struct Layer {
    id: String,
    // Boxed: a layer travels between threads and back in an error.
    frame: Box<Frame>,
    c: Box<Contribution>,
}

impl Layer {
    /// The obstacle's id.
    pub fn id(&self) -> &str {
        &self.id
    }
}

/// What an obstacle's part depends on besides the obstacle: grid, particles, anchor, path.
#[derive(Debug, Clone, PartialEq)]
struct Frame {
    cfg: RiskMapConfig,
    t0_bits: u64,
    path: Vec<[f64; 2]>,
}

fn fnv1a(s: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in s.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Calls `f` with each cell of `q` that contribution `c` covers and its particle count
/// there, slice by slice and run by run.
fn for_each_cell(
    q: &mut [f32],
    geo: &[SliceGeom],
    n_slices: usize,
    c: &Contribution,
    mut f: impl FnMut(&mut f32, u16),
) {
    for k in 0..n_slices {
        if geo[k].sparse {
            continue;
        }
        let base = geo[k].off;
        for (idx, counts) in c.slice_runs(k) {
            let a = base + idx;
            for (q, &n) in q[a..a + counts.len()].iter_mut().zip(counts) {
                f(q, n);
            }
        }
    }
}

impl Contribution {
    /// How far the particles' mean moves from slice `k` to slice `k + 1`, metres (0 where
    /// either slice has none).
    #[inline]
    fn mean_move(&self, k: usize) -> [f64; 2] {
        let (a, b) = (self.centre_m[k], self.centre_m[k + 1]);
        let d = [b[0] - a[0], b[1] - a[1]];
        if d[0].is_finite() && d[1].is_finite() {
            d
        } else {
            [0.0, 0.0]
        }
    }

    /// Slice `k`'s runs as (first cell within the slice, counts); none for a slice the
    /// contribution has no entry for (filtered, a NoFly disc).
    fn slice_runs(&self, k: usize) -> impl Iterator<Item = (usize, &[u16])> {
        let r = if k + 1 < self.slice_start.len() {
            self.slice_start[k] as usize..self.slice_start[k + 1] as usize
        } else {
            0..0
        };
        self.runs[r].iter().map(|run| {
            let counts = &self.counts[run.start as usize..(run.start + run.len) as usize];
            (run.idx as usize, counts)
        })
    }
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
        if cfg
            .nofly_horizon_s
            .is_some_and(|h| !(h.is_finite() && h >= 0.0))
        {
            return Err(RiskMapError::NotPositive("nofly_horizon_s"));
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
            let sparse = level == 0 && cfg.sparse_fine;
            geo.push(SliceGeom {
                inv_cell: 1.0 / cell_m,
                cell_m,
                off: total as usize,
                nx: lx as usize,
                ny: ly as usize,
                level: level as usize,
                sparse,
            });
            if !sparse {
                total += lx * ly;
            }
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
            mean_acc: [0.0; 3],
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

    /// The last time at which NoFly discs count ([`RiskMapConfig::nofly_horizon_s`] after
    /// slice 0; infinite without that limit).
    #[inline]
    fn disc_until_s(&self) -> f64 {
        self.cfg
            .nofly_horizon_s
            .map_or(f64::INFINITY, |h| self.t0_s + h + 1e-9)
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
        self.sub_stencil_area_m2(radius_m, k, SUB2 / 2)
    }

    /// Area of the stencil of sub-cell position `sub` in slice `k`, square metres.
    fn sub_stencil_area_m2(&mut self, radius_m: f64, k: usize, sub: usize) -> f64 {
        let g = self.geo[k.min(self.n_slices - 1)];
        let i = self.stencil(radius_m + self.cfg.buffer_m, g, sub);
        self.stencils[i].1.cells as f64 * g.cell_m * g.cell_m
    }

    /// The smallest and largest area of the splat stencils of a sphere of `radius_m` (plus
    /// the buffer) in slice `k` over the sub-cell positions a particle is splatted from
    /// (the cell centre alone without [`RiskMapConfig::subcell_splat`]), square metres: an
    /// obstacle's mass in a slice lies between them.
    pub fn slice_stencil_areas_m2(&mut self, radius_m: f64, k: usize) -> [f64; 2] {
        let mut out = [f64::INFINITY, 0.0f64];
        let subs = if self.cfg.subcell_splat {
            0..SUB2
        } else {
            SUB2 / 2..SUB2 / 2 + 1
        };
        for sub in subs {
            let a = self.sub_stencil_area_m2(radius_m, k, sub);
            out = [out[0].min(a), out[1].max(a)];
        }
        out
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
                if self.geo[k].sparse {
                    continue;
                }
                let base = self.geo[k].off;
                for run in &c.runs[c.slice_start[k] as usize..c.slice_start[k + 1] as usize] {
                    let a = base + run.idx as usize;
                    self.q[a..a + run.len as usize].fill(1.0);
                }
            }
        }
        // Keep the allocations for the next rebuild, as many as it can use: one per
        // obstacle just removed. Parts put in from other maps (`put_layer`, the helper's)
        // come with allocations of their own, so without the bound every rebuild of a map
        // fed by a helper added its parts to the spares for good (after one Webster Field
        // flight, 677 spare parts holding 64 MB beside the 0.2-0.8 MB in use).
        let old = std::mem::take(&mut self.contrib);
        let n = old.len();
        self.spare.extend(old.into_values().map(|mut c| {
            c.runs.clear();
            c.counts.clear();
            c.slice_start.clear();
            c
        }));
        let extra = self.spare.len().saturating_sub(n);
        self.spare.drain(..extra);
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
        let inv = &self.inv_table;
        for_each_cell(&mut self.q, &self.geo, self.n_slices, c, |q, n| {
            *q *= inv[usize::from(n)];
            // Snap the rounding drift of multiply-then-divide back to exactly 1.
            if *q > 1.0 - 1e-6 {
                *q = 1.0;
            }
        });
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
    /// Bytes this map holds on the heap (capacities, not lengths): its grids and scratch
    /// buffers, every obstacle's part, and the spare parts kept for the next rebuild.
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        fn v<T>(x: &Vec<T>) -> usize {
            x.capacity() * size_of::<T>()
        }
        let part = |c: &Contribution| {
            v(&c.runs)
                + v(&c.counts)
                + v(&c.slice_start)
                + v(&c.bbox_m)
                + v(&c.max_p)
                + v(&c.centre_m)
        };
        self.contrib.values().map(part).sum::<usize>()
            + self.spare.iter().map(part).sum::<usize>()
            + v(&self.path)
            + v(&self.geo)
            + v(&self.q)
            + v(&self.discs)
            + v(&self.omp_table)
            + v(&self.inv_table)
            + v(&self.mark)
            + v(&self.centres)
            + v(&self.diff)
            + v(&self.row_span)
            + v(&self.rows_touched)
            + v(&self.stamps)
    }

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
        c.centre_m.clear();
        c.speed_mps = o.model.speed_mps;
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

    fn frame(&self) -> Frame {
        Frame {
            cfg: self.cfg.clone(),
            t0_bits: self.t0_s.to_bits(),
            path: self.path.clone(),
        }
    }

    /// Removes obstacle `id`'s part from this map and returns it (see [`Layer`]); `None`
    /// when the map does not hold `id`.
    pub fn take_layer(&mut self, id: &str) -> Option<Layer> {
        let c = self.contrib.remove(id)?;
        self.subtract(&c);
        self.refresh_discs();
        Some(Layer {
            id: id.to_owned(),
            frame: Box::new(self.frame()),
            c: Box::new(c),
        })
    }

    /// Puts a layer taken from a map of the same frame (configuration, slice-0 time and
    /// intended path) in place of its obstacle's part here: the same cells, bit for bit,
    /// as [`RiskMap::update_obstacle`] with that obstacle's input on this map.
    ///
    /// # Errors
    /// The layer back when its map's frame differs from this one's.
    pub fn put_layer(&mut self, layer: Layer) -> Result<(), Layer> {
        if layer.frame.t0_bits != self.t0_s.to_bits()
            || layer.frame.cfg != self.cfg
            || layer.frame.path != self.path
        {
            return Err(layer);
        }
        if let Some(old) = self.contrib.remove(&layer.id) {
            self.subtract(&old);
        }
        let c = *layer.c;
        // The same multiplications, cell by cell, as the fold in `finish_slice`.
        let omp = &self.omp_table;
        for_each_cell(&mut self.q, &self.geo, self.n_slices, &c, |q, n| {
            if n > 0 {
                *q *= omp[usize::from(n)];
            }
        });
        self.contrib.insert(layer.id, c);
        self.refresh_discs();
        Ok(())
    }
}
