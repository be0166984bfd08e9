//! Writing an obstacle into the map: particles propagated with its stage's motion model
//! (or replayed from its earlier lap) are merged per cell and splatted with a disc stencil
//! through a row-difference scratch, leaving runs of per-cell particle counts that are
//! folded into the combined grid `q` in the same pass.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::{Contribution, ObstacleInput, RiskMap, Run, SUB, SUB2, SliceGeom, Stencil, fnv1a};
use crate::motion::Propagator;

/// Largest observation gap a lap replay interpolates across, seconds.
const LAP_MAX_GAP_S: f64 = 5.0;

impl RiskMap {
    /// The stencil of radius `r_m` at slice geometry `g` for a particle at sub-cell
    /// position `sub` (`sx + SUB * sy`): the cells whose centres lie within `r_m` of that
    /// position's centre, `(sx + 0.5) / SUB` of a cell from the cell's west edge (and `sy`
    /// from its south edge). The middle position is the cell centre.
    pub(super) fn stencil(&mut self, r_m: f64, g: SliceGeom, sub: usize) -> usize {
        let key = ((r_m * 1000.0).round() as u64, g.level, sub);
        if let Some(i) = self.stencils.iter().position(|(k, _)| *k == key) {
            return i;
        }
        let rc = r_m / g.cell_m;
        let ox = ((sub % SUB) as f64 + 0.5) / SUB as f64;
        let oy = ((sub / SUB) as f64 + 0.5) / SUB as f64;
        let mut rows = Vec::new();
        let (mut cells, mut extent) = (0, 0);
        let dy0 = (oy - 0.5 - rc).ceil() as i32;
        let dy1 = (oy - 0.5 + rc).floor() as i32;
        for dy in dy0..=dy1 {
            let ey = f64::from(dy) + 0.5 - oy;
            let rem = rc * rc - ey * ey;
            if rem < 0.0 {
                continue;
            }
            let w = rem.sqrt();
            let (x0, x1) = ((ox - 0.5 - w).ceil() as i32, (ox - 0.5 + w).floor() as i32);
            if x0 > x1 {
                continue;
            }
            rows.push((dy, x0, x1));
            cells += (x1 - x0 + 1) as usize;
            extent = extent.max(dy.abs()).max(x0.abs()).max(x1.abs());
        }
        self.stencils.push((
            key,
            Stencil {
                rows,
                cells,
                extent,
            },
        ));
        self.stencils.len() - 1
    }

    pub(super) fn splat_obstacle(&mut self, o: &ObstacleInput<'_>, r_m: f64, c: &mut Contribution) {
        // Stencils per resolution level (at most three) and sub-cell position.
        // Without sub-cell splatting every particle is at the middle position, whose
        // stencil stands for all nine.
        let mut si = [[usize::MAX; SUB2]; 3];
        let mut built = [false; 3];
        for k in 0..self.n_slices {
            let g = self.geo[k];
            if !built[g.level] {
                built[g.level] = true;
                let centre = self.stencil(r_m, g, SUB2 / 2);
                for (sub, s) in si[g.level].iter_mut().enumerate() {
                    *s = if self.cfg.subcell_splat {
                        self.stencil(r_m, g, sub)
                    } else {
                        centre
                    };
                }
            }
        }
        let n = self.cfg.particles;
        let mut rng = ChaCha8Rng::seed_from_u64(self.cfg.seed ^ fnv1a(o.id));
        let mut prop =
            Propagator::with_replay(o.model, o.manoeuvres.map(|m| (o.track, m)), n, &mut rng);
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
            } else if let Some(at) = o
                .model
                .lap
                .and_then(|lap| lap.at(o.track, tk - o.model.t_s, LAP_MAX_GAP_S))
            {
                // Before the rest test: a lap predicts where the obstacle goes even while
                // it is at rest now (the turn-back of an out-and-back), as
                // `Predictor::sample_future` does.
                for z in &lap_z {
                    self.add_particle(at.particle(*z), 1);
                }
            } else if o.model.speed_mps <= 0.0 && !prop.moves() {
                self.add_particle(o.model.position_m, all);
            } else {
                prop.advance_to(tk, &mut rng);
                for p in prop.positions() {
                    self.add_particle(p, 1);
                }
            }
            self.finish_slice(&si[self.cur.level], c);
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
        self.mean_acc = [0.0; 3];
    }

    /// Merges a particle into its cell and sub-cell position; a particle outside the grid
    /// is stamped on its own (its stencil may still reach the grid).
    fn add_particle(&mut self, p: [f64; 2], w: u32) {
        let wf = f64::from(w);
        self.mean_acc[0] += wf * p[0];
        self.mean_acc[1] += wf * p[1];
        self.mean_acc[2] += wf;
        let g = &self.cur;
        let fx = (p[0] - self.cfg.min_m[0]) * g.inv_cell;
        let fy = (p[1] - self.cfg.min_m[1]) * g.inv_cell;
        // The middle position (the cell centre) when sub-cell splatting is off.
        let on = self.cfg.subcell_splat;
        let sub_of = |f: f64, i: f64| {
            if on {
                (((f - i) * SUB as f64) as usize).min(SUB - 1)
            } else {
                SUB / 2
            }
        };
        // Inside the grid the truncating casts are the floor (no libm call on this path).
        if fx >= 0.0 && fy >= 0.0 && fx < g.nx as f64 && fy < g.ny as f64 {
            let (ix, iy) = (fx as usize, fy as usize);
            let sub = sub_of(fx, ix as f64) + SUB * sub_of(fy, iy as f64);
            let j = iy * g.nx + ix;
            let m = &mut self.mark[j];
            if m.0 != self.stamp_gen {
                *m = (self.stamp_gen, self.centres.len() as u32);
                let mut counts = [0; SUB2];
                counts[sub] = w;
                self.centres.push((j as u32, counts));
            } else {
                self.centres[m.1 as usize].1[sub] += w;
            }
        } else {
            let (ix, iy) = (fx.floor(), fy.floor());
            let sub = sub_of(fx, ix) + SUB * sub_of(fy, iy);
            self.stamps.push((
                ix.clamp(-1e8, 1e8) as i32,
                iy.clamp(-1e8, 1e8) as i32,
                w,
                sub as u32,
            ));
        }
    }

    /// Splats the slice's merged centres into a dense buffer over their bounding box
    /// (contiguous row additions), then keeps the non-zero cells as the slice's entries.
    #[inline(never)]
    fn finish_slice(&mut self, si: &[usize; SUB2], c: &mut Contribution) {
        let g = self.cur;
        let nx = g.nx as i32;
        let ny = g.ny as i32;
        for &(j, counts) in &self.centres {
            let j = j as usize;
            for (sub, &w) in counts.iter().enumerate() {
                if w > 0 {
                    self.stamps
                        .push(((j % g.nx) as i32, (j / g.nx) as i32, w, sub as u32));
                }
            }
        }
        let rc = si
            .iter()
            .map(|&i| self.stencils[i].1.extent)
            .max()
            .unwrap_or(0);
        let (mut bx0, mut by0, mut bx1, mut by1) = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
        for &(cx, cy, _, _) in &self.stamps {
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
            for &(cx, cy, w, sub) in &self.stamps {
                let stencil = &self.stencils[si[sub as usize]].1;
                for &(dy, lo, hi) in &stencil.rows {
                    let y = cy + dy;
                    if y < by0 || y > by1 {
                        continue;
                    }
                    let x0 = (cx + lo).max(bx0);
                    let x1 = (cx + hi).min(bx1);
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
                        // Fold the contribution into the combined grid in the same pass
                        // (a sparse slice has none: it is read from the runs).
                        if !g.sparse {
                            self.q[qbase + gbase + xx] *= self.omp_table[n as usize];
                        }
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
        let [sx, sy, sw] = self.mean_acc;
        c.centre_m.push(if sw > 0.0 {
            [sx / sw, sy / sw]
        } else {
            [f64::NAN; 2]
        });
    }
}
