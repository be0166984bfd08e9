//! Reading the map: `risk(point, t)` (the worse of the two bracketing slices; between two
//! sparse slices each obstacle read where its cloud is at `t`), whole slices for rendering,
//! and the conservative segment bound the planner prunes with.

use super::RiskMap;
use super::SliceView;
use crate::field::RiskField;

impl RiskMap {
    #[inline]
    fn disc_risk(&self, p_m: [f64; 2], k: usize) -> f64 {
        let tk = self.slice_time(k);
        if tk > self.disc_until_s() {
            return 0.0;
        }
        for d in &self.discs {
            let r = d.r0_m + d.growth_mps * (tk - d.t_ref_s).max(0.0);
            let (dx, dy) = (p_m[0] - d.c[0], p_m[1] - d.c[1]);
            if dx * dx + dy * dy <= r * r {
                return 1.0;
            }
        }
        0.0
    }

    /// Every obstacle's part but the filtered ones, in the map's order, none read at a
    /// fast weight.
    #[inline]
    pub(super) fn unfiltered(&self) -> impl Iterator<Item = (&super::Contribution, bool)> {
        self.contrib
            .values()
            .filter(|c| !c.filtered)
            .map(|c| (c, false))
    }

    /// The slice nearest `t_s`, for rendering.
    pub fn slice(&self, t_s: f64) -> SliceView {
        let k = self.slice_index(t_s);
        let g = self.geo[k];
        let mut data: Vec<f32> = if g.sparse {
            self.sparse_grid(k)
        } else {
            self.q[g.off..g.off + g.nx * g.ny].to_vec()
        };
        for q in &mut data {
            *q = (1.0 - *q).clamp(0.0, 1.0);
        }
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

    /// Slice `k`'s `prod(1 - p_i)` per cell, from the obstacles' runs (a sparse slice's
    /// grid, for rendering), multiplied in the map's order as a fold into `q` would be.
    fn sparse_grid(&self, k: usize) -> Vec<f32> {
        let g = self.geo[k];
        let mut q = vec![1.0f32; g.nx * g.ny];
        for c in self.contrib.values().filter(|c| !c.filtered) {
            for (a, counts) in c.slice_runs(k) {
                for (q, &n) in q[a..a + counts.len()].iter_mut().zip(counts) {
                    if n > 0 {
                        *q *= self.omp_table[usize::from(n)];
                    }
                }
            }
        }
        q
    }

    /// Risk of slice `k` at `p_m` (grid and NoFly discs; a sparse slice from the runs of
    /// the obstacles whose slice box or disc holds the point).
    #[inline]
    pub(super) fn slice_risk(&self, p_m: [f64; 2], k: usize) -> f64 {
        let g = &self.geo[k];
        if g.sparse {
            return self.slice_risk_of(p_m, k, self.unfiltered(), None);
        }
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

    /// The worse of `slice_risk(k)` over the slices bracketing `t_s` (the second read only
    /// while the first is under 1), within `[0, 1]`.
    #[inline]
    pub(super) fn worse_of_bracket(&self, t_s: f64, slice_risk: impl Fn(usize) -> f64) -> f64 {
        let (k0, k1) = self.bracket(t_s);
        let mut r = slice_risk(k0);
        if k1 != k0 && r < 1.0 {
            r = r.max(slice_risk(k1));
        }
        r.clamp(0.0, 1.0)
    }

    /// `t_s` strictly between two sparse slices ([`RiskMapConfig::sparse_fine`]):
    /// `Some((k, w))` with `t_k < t_s < t_(k+1)` and `w = (t_s - t_k) / dt`.
    ///
    /// [`RiskMapConfig::sparse_fine`]: super::RiskMapConfig::sparse_fine
    #[inline]
    pub(super) fn sparse_between(&self, t_s: f64) -> Option<(usize, f64)> {
        let (k0, k1) = self.bracket(t_s);
        (k1 != k0 && self.geo[k1].sparse).then(|| {
            (
                k0,
                ((t_s - self.slice_time(k0)) * self.inv_dt).clamp(0.0, 1.0),
            )
        })
    }

    /// The slices bracketing `t_s`: `(k, k)` at a slice time (or outside the horizon),
    /// else `(k, k + 1)` with `t_k < t_s < t_(k+1)`.
    #[inline]
    pub(super) fn bracket(&self, t_s: f64) -> (usize, usize) {
        let f = (t_s - self.t0_s) * self.inv_dt;
        if f <= 0.0 {
            return (0, 0);
        }
        // `f.floor()` for this positive `f` (NaN gives 0 both ways), without libm's call:
        // every risk read brackets its time.
        let k = (f as u64) as f64;
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
    /// a 1 s slice, more than the buffer: reading the nearest slice alone could miss it);
    /// between two sparse slices each obstacle is read where its cloud is at `t_s`, the
    /// worse of the two slices each moved by the cloud's mean move.
    #[inline]
    fn risk(&self, p_m: [f64; 2], t_s: f64) -> f64 {
        if let Some((k, w)) = self.sparse_between(t_s) {
            return self
                .between_risk_of(p_m, k, w, self.unfiltered(), None)
                .clamp(0.0, 1.0);
        }
        self.worse_of_bracket(t_s, |k| self.slice_risk(p_m, k))
    }

    /// Conservative: `1 - prod(1 - peak_i)` over every obstacle whose slice bounding box
    /// meets the segment's bounding box in a slice the segment's times map to; 1 if the
    /// segment comes within a NoFly disc (as it is at the later of the segment's slices,
    /// or at the end of [`crate::RiskMapConfig::nofly_horizon_s`]).
    fn segment_risk_bound(&self, a_m: [f64; 2], b_m: [f64; 2], t0_s: f64, t1_s: f64) -> f64 {
        self.segment_bound_of(a_m, b_m, t0_s, t1_s, self.unfiltered(), None)
    }
}
