//! Reading the map for one altitude band of the aircraft ([`AltitudeView`]): the map holds
//! every obstacle the route may meet, one grid for all of them; a leg flown above or below
//! some of them reads the map without those (issue 10, "3-D obstacles": the aircraft's
//! altitude along the plan decides whether it passes over or under a sphere).
//!
//! Where none of the obstacles left out covers the point in the slice read (its slice
//! bounding box, or its NoFly disc), the answer is the grid's, unchanged; where one does,
//! the product `prod(1 - p_i)` is recomputed over the obstacles kept, each obstacle's count
//! at the cell looked up in its runs (a binary search within the slice).

use super::{Contribution, RiskMap};
use crate::field::RiskField;
use geom::dist_point_segment;

/// How far an obstacle's slice box is widened when a point or segment is tested against
/// it, metres (the cell a point reads can be one its coordinates round into).
const BOX_EPS_M: f64 = 1e-6;

/// Obstacles with a reach an [`AltitudeView`] keeps: one bit each of a 64-bit mask, never
/// all of them ([`crate::field::NO_BAND_HINT`]).
pub const MAX_REACH: usize = 63;

/// A [`RiskMap`] with each obstacle's altitude reach: [`RiskField::risk_in_band`] leaves
/// out the obstacles whose reach misses the band asked about, and every read leaves out
/// those that reach no altitude at all (as if removed from the map, without copying it).
#[derive(Debug, Clone)]
pub struct AltitudeView<'a> {
    map: &'a RiskMap,
    /// Obstacles with a reach, as `(contribution, [lowest, highest] altitude it can
    /// touch)`, `None` for none; obstacles not listed reach every altitude.
    reach: Vec<(&'a Contribution, Option<[f64; 2]>)>,
    /// Every unfiltered contribution of the map, in the map's own order (so a product over
    /// them rounds as the map's does), with the bits of `reach` naming it (0: none): a read
    /// with a mask keeps those whose bits the mask misses, without walking the map's tree
    /// or `reach` for each obstacle at each point.
    order: Vec<(&'a Contribution, u64)>,
    /// [`AltitudeView::fast_weight`] and [`AltitudeView::fast_weights`]: per slice of the
    /// map, the weight fast obstacles are read at, with the first and last slice whose
    /// weight is not 1; `None`: every obstacle at weight 1.
    fast: Option<(Vec<f64>, usize, usize)>,
    /// Per entry of `order`, whether the obstacle is read at the `fast` weight.
    is_fast: Vec<bool>,
}

impl RiskMap {
    /// This map read per altitude band: `reach` gives, per obstacle id, the lowest and
    /// highest altitude (metres MSL) its sphere plus buffer can touch over the horizon, or
    /// `None` when it can touch none the map is read for. Ids the map does not hold are
    /// ignored; obstacles without a reach, and those after the first [`MAX_REACH`] with
    /// one, count at every altitude (conservative).
    pub fn altitude_view<'a, I, S>(&'a self, reach: I) -> AltitudeView<'a>
    where
        I: IntoIterator<Item = (S, Option<[f64; 2]>)>,
        S: AsRef<str>,
    {
        let reach = reach
            .into_iter()
            .filter_map(|(id, band)| {
                self.contrib
                    .get(id.as_ref())
                    .filter(|c| !c.filtered)
                    .map(|c| (c, band))
            })
            .take(MAX_REACH)
            .collect::<Vec<_>>();
        let order: Vec<(&Contribution, u64)> = self
            .contrib
            .values()
            .filter(|c| !c.filtered)
            .map(|c| {
                let bits = reach
                    .iter()
                    .enumerate()
                    .filter(|(_, (r, _))| std::ptr::eq(*r, c))
                    .fold(0u64, |m, (i, _)| m | (1 << i));
                (c, bits)
            })
            .collect();
        let is_fast = vec![false; order.len()];
        AltitudeView {
            map: self,
            reach,
            order,
            fast: None,
            is_fast,
        }
    }

    /// Obstacle `c`'s particle count at cell `cell` of slice `k` (0 outside its runs).
    fn count_at(c: &Contribution, k: usize, cell: u32) -> u16 {
        let (s0, s1) = (c.slice_start[k] as usize, c.slice_start[k + 1] as usize);
        let runs = &c.runs[s0..s1];
        let i = runs.partition_point(|r| r.idx <= cell);
        if i == 0 {
            return 0;
        }
        let r = runs[i - 1];
        if cell < r.idx + r.len {
            c.counts[(r.start + cell - r.idx) as usize]
        } else {
            0
        }
    }

    /// Whether obstacle `c` puts any risk at `p_m` in slice `k` (its slice bounding box,
    /// or its NoFly disc).
    fn touches(&self, c: &Contribution, p_m: [f64; 2], k: usize) -> bool {
        if let Some(d) = c.disc {
            let tk = self.slice_time(k);
            if tk > self.disc_until_s() {
                return false;
            }
            let r = d.r0_m + d.growth_mps * (tk - d.t_ref_s).max(0.0);
            let (dx, dy) = (p_m[0] - d.c[0], p_m[1] - d.c[1]);
            return dx * dx + dy * dy <= r * r;
        }
        meets(c.bbox_m[k], [p_m[0], p_m[1], p_m[0], p_m[1]])
    }

    /// Risk of slice `k` at `p_m` from the contributions `kept` (unfiltered ones, in the
    /// map's order), each with whether it is read at the fast weight of its slice
    /// (`fast_w`, per slice; [`AltitudeView::fast_weights`]; 1 for the others).
    pub(super) fn slice_risk_of<'c>(
        &self,
        p_m: [f64; 2],
        k: usize,
        kept: impl Iterator<Item = (&'c Contribution, bool)>,
        fast_w: Option<&[f64]>,
    ) -> f64 {
        let cell = self.cell_of(p_m, k);
        let w_k = fast_w.map_or(1.0, |w| w[k]);
        let mut q = 1.0f64;
        for (c, fast) in kept {
            let weight = if fast { w_k } else { 1.0 };
            if !self.touches(c, p_m, k) {
                continue;
            }
            if c.disc.is_some() {
                return 1.0;
            }
            if let Some(cell) = cell {
                let n = Self::count_at(c, k, cell);
                if n > 0 {
                    q *= f64::from(self.omp_table[self.weighted(n, weight)]);
                }
            }
        }
        1.0 - q
    }

    /// Risk at `p_m` at the fraction `w` of the way from sparse slice `k` to slice `k + 1`
    /// from the contributions `kept` (unfiltered ones, in the map's order): each obstacle
    /// read in both slices where its cloud was, moved by its mean's move between them
    /// (`p - w d` in slice `k`, `p + (1 - w) d` in `k + 1`), the larger count kept; a NoFly
    /// disc as either slice has it. A cloud that moves as a whole is read where it is at
    /// `t`, not over both slices' places (the worse of the two slices at `p`, which put the
    /// edge of a 20 m/s sphere up to 10 m ahead of and behind where it is between 0.5 s
    /// slices).
    pub(super) fn between_risk_of<'c>(
        &self,
        p_m: [f64; 2],
        k: usize,
        w: f64,
        kept: impl Iterator<Item = (&'c Contribution, bool)>,
        fast_w: Option<&[f64]>,
    ) -> f64 {
        let slice_w = [k, k + 1].map(|kk| fast_w.map_or(1.0, |fw| fw[kk]));
        let mut q = 1.0f64;
        for (c, fast) in kept {
            if c.disc.is_some() {
                if self.touches(c, p_m, k) || self.touches(c, p_m, k + 1) {
                    return 1.0;
                }
                continue;
            }
            let d = c.mean_move(k);
            let mut n = 0usize;
            for ((kk, s), w_kk) in [(k, -w), (k + 1, 1.0 - w)].into_iter().zip(slice_w) {
                let at = [p_m[0] + s * d[0], p_m[1] + s * d[1]];
                if self.touches(c, at, kk)
                    && let Some(cell) = self.cell_of(at, kk)
                {
                    let weight = if fast { w_kk } else { 1.0 };
                    n = n.max(self.weighted(Self::count_at(c, kk, cell), weight));
                }
            }
            if n > 0 {
                q *= f64::from(self.omp_table[n]);
            }
        }
        1.0 - q
    }

    /// Count `n` of an obstacle read at `weight` ([`AltitudeView::fast_weights`]), as an
    /// index of the one-minus-p table: `weight * n` rounded, at most every particle.
    #[inline]
    fn weighted(&self, n: u16, weight: f64) -> usize {
        if weight == 1.0 {
            return usize::from(n).min(self.cfg.particles);
        }
        ((f64::from(n) * weight).round().max(0.0) as usize).min(self.cfg.particles)
    }

    /// The cell of slice `k` holding `p_m` (`None` outside the grid).
    #[inline]
    fn cell_of(&self, p_m: [f64; 2], k: usize) -> Option<u32> {
        let g = &self.geo[k];
        let fx = (p_m[0] - self.cfg.min_m[0]) * g.inv_cell;
        let fy = (p_m[1] - self.cfg.min_m[1]) * g.inv_cell;
        (fx >= 0.0 && fy >= 0.0)
            .then_some((fx as usize, fy as usize))
            .filter(|&(ix, iy)| ix < g.nx && iy < g.ny)
            .map(|(ix, iy)| (iy * g.nx + ix) as u32)
    }

    /// [`RiskField::segment_risk_bound`] over the contributions `kept` (unfiltered ones, in
    /// the map's order).
    pub(super) fn segment_bound_of<'c>(
        &self,
        a_m: [f64; 2],
        b_m: [f64; 2],
        t0_s: f64,
        t1_s: f64,
        kept: impl Iterator<Item = (&'c Contribution, bool)>,
        fast_w: Option<&[f64]>,
    ) -> f64 {
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
        let mut keep_p = 1.0f64;
        for (c, fast) in kept {
            if let Some(d) = c.disc {
                let until = self.disc_until_s();
                if self.slice_time(k0) > until {
                    continue;
                }
                let t = self.slice_time(k1).min(until);
                let r = d.r0_m + d.growth_mps * (t - d.t_ref_s).max(0.0);
                if dist_point_segment(d.c, a_m, b_m) <= r {
                    return 1.0;
                }
                continue;
            }
            let meets = |bb: [f64; 4]| meets(bb, sb);
            // Slice k's peak at the weight it is read at.
            let peak_at = |k: usize| {
                let w = match fast_w {
                    Some(fw) if fast => fw[k],
                    _ => 1.0,
                };
                (w * f64::from(c.max_p[k])).min(1.0)
            };
            let mut peak: f64 = 0.0;
            for k in k0..=k1 {
                if meets(c.bbox_m[k]) {
                    peak = peak.max(peak_at(k));
                }
                // A read between two sparse slices looks at each where the cloud was,
                // moved by the mean's move: within each box swept along that move.
                if k < k1 && self.geo[k + 1].sparse {
                    let d = c.mean_move(k);
                    if meets(swept(c.bbox_m[k], d)) || meets(swept(c.bbox_m[k + 1], [-d[0], -d[1]]))
                    {
                        peak = peak.max(peak_at(k)).max(peak_at(k + 1));
                    }
                }
            }
            keep_p *= 1.0 - peak;
        }
        (1.0 - keep_p).clamp(0.0, 1.0)
    }
}

/// Whether slice box `bb` meets box `sb` (`[x0, y0, x1, y1]`, a point as a box of no
/// size), `bb` widened by [`BOX_EPS_M`]: a point within that of a box edge can round into
/// the cell inside it (`p - min` rounds up to the edge's multiple of the cell).
#[inline]
fn meets(bb: [f64; 4], sb: [f64; 4]) -> bool {
    bb[0] - BOX_EPS_M <= sb[2]
        && sb[0] <= bb[2] + BOX_EPS_M
        && bb[1] - BOX_EPS_M <= sb[3]
        && sb[1] <= bb[3] + BOX_EPS_M
}

/// The bounding box of `bb` moved by `w d` for every `w` in `[0, 1]`.
fn swept(bb: [f64; 4], d: [f64; 2]) -> [f64; 4] {
    [
        bb[0].min(bb[0] + d[0]),
        bb[1].min(bb[1] + d[1]),
        bb[2].max(bb[2] + d[0]),
        bb[3].max(bb[3] + d[1]),
    ]
}

/// Whether an obstacle of reach `reach` is left out of a read for `band_m` (`None`: a read
/// for every altitude).
fn misses(reach: Option<[f64; 2]>, band_m: Option<[f64; 2]>) -> bool {
    match (reach, band_m) {
        (None, _) => true,
        (Some(r), Some(b)) => r[1] < b[0] || r[0] > b[1],
        (Some(_), None) => false,
    }
}

impl AltitudeView<'_> {
    /// Reads every obstacle whose speed (its motion model's, when it was put in the map)
    /// is above `above_mps` at `weight` times its probability, at most 1, in the slices
    /// at most `within_s` after the map's slice 0; other obstacles, and every obstacle in
    /// later slices, at their own. With `above_mps` the aircraft's speed, `weight` 2 and
    /// `within_s` the planner's near window, an obstacle the aircraft cannot outrun is held
    /// to half the near limit (`planner::VerifyParams::fast_weight`). A weight of 1 (or 0)
    /// changes nothing. A read between the window's last slice and the next reads the
    /// former at the weight and the latter at 1 (the weight goes by slice).
    #[must_use]
    pub fn fast_weight(self, above_mps: f64, weight: u32, within_s: f64) -> Self {
        if weight <= 1 {
            return self;
        }
        let w = f64::from(weight);
        self.fast_weights(
            above_mps,
            |at_s| if at_s <= within_s + 1e-9 { w } else { 1.0 },
        )
    }

    /// Reads every obstacle whose speed (its motion model's, when it was put in the map)
    /// is above `above_mps` at `weight(t)` times its probability (its particle count
    /// scaled and rounded, at most 1) in the slice `t` seconds after the map's slice 0;
    /// other obstacles at their own. The weight goes by slice: a read between two slices
    /// reads each at its own. A weight of 1 in every slice changes nothing.
    #[must_use]
    pub fn fast_weights(mut self, above_mps: f64, weight: impl Fn(f64) -> f64) -> Self {
        let m = self.map;
        let w: Vec<f64> = (0..m.slices())
            .map(|k| weight(m.slice_time(k) - m.t0_s()).max(0.0))
            .collect();
        let (Some(first), Some(last)) = (
            w.iter().position(|&x| x != 1.0),
            w.iter().rposition(|&x| x != 1.0),
        ) else {
            return self;
        };
        self.is_fast = self
            .order
            .iter()
            .map(|(c, _)| c.disc.is_none() && c.speed_mps > above_mps)
            .collect();
        self.fast = self.is_fast.iter().any(|&f| f).then_some((w, first, last));
        self
    }

    /// The per-slice weights of fast obstacles when any slice from `k0` to `k1` reads one
    /// at a weight other than 1.
    #[inline]
    fn weights_in(&self, k0: usize, k1: usize) -> Option<&[f64]> {
        match &self.fast {
            Some((w, first, last)) if k0 <= *last && k1 >= *first => Some(w.as_slice()),
            _ => None,
        }
    }

    /// The entries of `reach` left out of a read for `band_m` (`None`: a read for every
    /// altitude), bit `i` for entry `i`.
    fn mask(&self, band_m: Option<[f64; 2]>) -> u64 {
        self.reach
            .iter()
            .enumerate()
            .filter(|(_, (_, r))| misses(*r, band_m))
            .fold(0, |m, (i, _)| m | (1 << i))
    }

    /// The contributions a read with `mask` keeps, in the map's order, each with whether
    /// it is read at the fast weight.
    fn kept(&self, mask: u64) -> impl Iterator<Item = (&Contribution, bool)> {
        self.order
            .iter()
            .zip(&self.is_fast)
            .filter(move |&(&(_, bits), _)| bits & mask == 0)
            .map(move |(&(c, _), &fast)| (c, fast))
    }

    /// Risk of slice `k` at `p_m` without the entries of `mask`, fast obstacles at their
    /// weight.
    fn slice_risk_masked(&self, p_m: [f64; 2], k: usize, mask: u64) -> f64 {
        let m = self.map;
        let fast_w = self.weights_in(k, k);
        if fast_w.is_some() || Bits(mask).any(|i| m.touches(self.reach[i].0, p_m, k)) {
            m.slice_risk_of(p_m, k, self.kept(mask), fast_w)
        } else {
            m.slice_risk(p_m, k)
        }
    }

    /// The worse of the two slices bracketing `t_s`, as [`RiskMap`]'s `risk`, without the
    /// entries of `mask` (none, and no weight: the map's own read, one load per slice).
    fn read(&self, p_m: [f64; 2], t_s: f64, mask: u64) -> f64 {
        let (k0, k1) = self.map.bracket(t_s);
        let fast_w = self.weights_in(k0, k1);
        if mask == 0 && fast_w.is_none() {
            return self.map.risk(p_m, t_s);
        }
        if let Some((k, w)) = self.map.sparse_between(t_s) {
            return self
                .map
                .between_risk_of(p_m, k, w, self.kept(mask), fast_w)
                .clamp(0.0, 1.0);
        }
        self.map
            .worse_of_bracket(t_s, |k| self.slice_risk_masked(p_m, k, mask))
    }

    /// The segment bound without the entries of `mask` (fast obstacles at their weight in
    /// each slice: still a bound of `read`).
    fn bound(&self, a_m: [f64; 2], b_m: [f64; 2], t0_s: f64, t1_s: f64, mask: u64) -> f64 {
        let (k0, k1) = (
            self.map.bracket(t0_s.min(t1_s)).0,
            self.map.bracket(t0_s.max(t1_s)).1,
        );
        let fast_w = self.weights_in(k0, k1);
        if mask == 0 && fast_w.is_none() {
            return self.map.segment_risk_bound(a_m, b_m, t0_s, t1_s);
        }
        self.map
            .segment_bound_of(a_m, b_m, t0_s, t1_s, self.kept(mask), fast_w)
    }
}

/// The set bits of a mask, lowest first.
struct Bits(u64);

impl Iterator for Bits {
    type Item = usize;
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            return None;
        }
        let i = self.0.trailing_zeros() as usize;
        self.0 &= self.0 - 1;
        Some(i)
    }
}

impl RiskField for AltitudeView<'_> {
    /// The map without the obstacles that reach no altitude.
    fn risk(&self, p_m: [f64; 2], t_s: f64) -> f64 {
        self.read(p_m, t_s, self.mask(None))
    }

    fn segment_risk_bound(&self, a_m: [f64; 2], b_m: [f64; 2], t0_s: f64, t1_s: f64) -> f64 {
        self.bound(a_m, b_m, t0_s, t1_s, self.mask(None))
    }

    /// The worse of the two bracketing slices, as [`RiskMap`]'s `risk`, without the
    /// obstacles whose reach misses `band_m`.
    fn risk_in_band(&self, p_m: [f64; 2], t_s: f64, band_m: [f64; 2]) -> f64 {
        self.read(p_m, t_s, self.mask(Some(band_m)))
    }

    /// Bit `i` set: the `i`-th obstacle with a reach is left out of reads for `band_m`.
    fn band_hint(&self, band_m: [f64; 2]) -> u64 {
        self.mask(Some(band_m))
    }

    /// [`RiskField::risk_in_band`], with the obstacles left out named by `hint`.
    fn risk_in_band_hinted(&self, p_m: [f64; 2], t_s: f64, band_m: [f64; 2], hint: u64) -> f64 {
        if hint == crate::field::NO_BAND_HINT {
            return self.risk_in_band(p_m, t_s, band_m);
        }
        self.read(p_m, t_s, hint)
    }

    fn segment_risk_bound_in_band(
        &self,
        a_m: [f64; 2],
        b_m: [f64; 2],
        t0_s: f64,
        t1_s: f64,
        band_m: [f64; 2],
    ) -> f64 {
        self.bound(a_m, b_m, t0_s, t1_s, self.mask(Some(band_m)))
    }
}
