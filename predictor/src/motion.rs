//! Motion models of the characterization stages and their particle propagation (seed 002,
//! "Random probability mapping", "Advanced probability mapping", "Consideration of past
//! behavior"; the NoFly disc of "No fly zones" is analytic).
//!
//! Every model flies at the constant estimated speed and redraws its turn rate at each
//! decision boundary `k * decision_interval_s` (the same clock the turn samples use):
//! - Random: uniform over `[-w_max, w_max]`;
//! - Advanced: a bin from the smoothed histogram, uniform within the bin;
//! - Memory: a bin from the smoothed histogram conditioned on the slice of the previous
//!   bin, uniform within the bin.
//!
//! Turn rates are drawn on a lattice of `LEVELS_PER_BIN` evenly spaced levels per bin, so
//! that the arc of one step is a table lookup (no trigonometry per particle and step);
//! arcs are integrated exactly.
//!
//! # Units
//! ENU metres, seconds, radians (heading counter-clockwise from east), m/s.

use crate::estimate::Estimates;
use crate::replay::{Manoeuvres, Novel, ReplayConfig, ReplayParticles};
use crate::stage::{Stage, StageConfig, TurnHistogram, slice_of};
use crate::stats::smoothed;
use crate::track::Track;
use crate::young::YoungModel;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

/// Lattice levels per histogram bin.
pub const LEVELS_PER_BIN: usize = 8;

/// Everything needed to propagate one obstacle forward from its last observation.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionModel {
    /// The stage whose model this is.
    pub stage: Stage,
    /// Start time (the newest observation), seconds.
    pub t_s: f64,
    /// Start position, ENU metres.
    pub position_m: [f64; 2],
    /// Start heading, radians counter-clockwise from east.
    pub heading_rad: f64,
    /// Constant speed, m/s.
    pub speed_mps: f64,
    /// Turn-rate capability, rad/s: the range of the Random stage's uniform draw and the
    /// scale of the histograms' bins.
    pub w_max_radps: f64,
    /// The largest turn rate a particle flies at the model's speed, rad/s (drawn rates are
    /// clamped to it): the estimate's capability at the current speed
    /// ([`Estimates::turn_rate_max_dps`], bounded by the demonstrated lateral
    /// acceleration). An obstacle that turned tightly only when slow (a spline tour's
    /// reversal) keeps its histogram, but its particles do not spin at that rate while it
    /// cruises.
    pub turn_limit_radps: f64,
    /// Decision interval, seconds.
    pub decision_interval_s: f64,
    /// NoFly growth speed, m/s.
    pub nofly_speed_mps: f64,
    /// Number of histogram bins.
    pub bins: usize,
    /// Cumulative bin probabilities per row, scaled to `u32` (one row for Advanced, one per
    /// slice for Memory, empty for Random and NoFly).
    cdf: Vec<Vec<u32>>,
    /// Slice of each bin (for Memory).
    slice_of_bin: Vec<usize>,
    /// Bin of the most recent turn sample.
    last_bin: Option<usize>,
    /// Spread of the particles' start position, metres per axis.
    pub start_position_sigma_m: f64,
    /// Spread of the particles' start heading, radians.
    pub start_heading_sigma_rad: f64,
    /// A recognized lap of a periodic tour: when set, positions after `t_s` are replayed
    /// from the obstacle's own earlier lap ([`crate::periodic`]) instead of propagated.
    pub lap: Option<crate::periodic::Lap>,
    /// Manoeuvre replay ([`crate::replay`]): when set, a propagator given the obstacle's
    /// track and frames ([`Propagator::with_replay`]) replays stretches of its own past
    /// instead of drawing turn rates.
    pub replay: Option<ReplayModel>,
    /// A young track's quadratic ([`crate::young`]): when set (never with `replay` or
    /// `lap`), particles fly it before turning as the stage model does.
    pub young: Option<YoungModel>,
    /// A spline tour's present leg ([`crate::leg::fit`]): when set, its share of the
    /// particles fly the leg's cubic to their knot, the others the model above.
    pub leg: Option<YoungModel>,
    /// Added to every turn rate the stage model draws (then clamped to the capability),
    /// rad/s, counter-clockwise positive: a young track's shown bias
    /// ([`crate::young::turn_bias_radps`]); 0 otherwise.
    pub turn_bias_radps: f64,
}

/// How an obstacle's own past is replayed ([`crate::replay`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplayModel {
    /// The replay parameters.
    pub cfg: ReplayConfig,
    /// Fastest average speed over 5 s of the replayed memory, m/s (bounds the reach).
    pub max_speed_mps: f64,
}

fn cdf_u32(p: &[f64]) -> Vec<u32> {
    let mut acc = 0.0;
    let mut out: Vec<u32> = p
        .iter()
        .map(|x| {
            acc += x;
            (acc * 4_294_967_296.0).min(4_294_967_295.0) as u32
        })
        .collect();
    if let Some(l) = out.last_mut() {
        *l = u32::MAX;
    }
    out
}

impl MotionModel {
    /// Builds the model of `stage` from the estimates and histograms.
    pub fn new(
        stage: Stage,
        est: &Estimates,
        hist: &TurnHistogram,
        decision_interval_s: f64,
        nofly_speed_mps: f64,
        cfg: &StageConfig,
    ) -> Self {
        let turn_limit_radps = if est.speed_mps > 0.0 {
            est.turn_rate_max_dps.to_radians()
        } else {
            hist.w_max_radps
        };
        let cdf = match stage {
            Stage::NoFly | Stage::Random => Vec::new(),
            Stage::Advanced => vec![cdf_u32(&smoothed(&hist.counts, cfg.smoothing_alpha))],
            Stage::Memory => hist
                .table
                .iter()
                .map(|row| cdf_u32(&smoothed(row, cfg.smoothing_alpha)))
                .collect(),
        };
        Self {
            stage,
            t_s: est.t_s,
            position_m: est.position_m,
            heading_rad: est.velocity_mps[1].atan2(est.velocity_mps[0]),
            speed_mps: est.speed_mps,
            // The Random stage draws over the capability at the current speed; the
            // histograms keep their own scale and their draws are clamped to it.
            w_max_radps: if stage == Stage::Random {
                turn_limit_radps
            } else {
                hist.w_max_radps
            },
            turn_limit_radps,
            decision_interval_s,
            nofly_speed_mps,
            bins: cfg.turn_bins,
            cdf,
            slice_of_bin: (0..cfg.turn_bins).map(|b| slice_of(b, cfg)).collect(),
            last_bin: hist.last_bin,
            start_position_sigma_m: cfg.start_position_sigma_m,
            start_heading_sigma_rad: cfg.start_heading_sigma_rad,
            lap: None,
            replay: None,
            young: None,
            leg: None,
            turn_bias_radps: 0.0,
        }
    }

    /// How far the obstacle can be from its start position after `dt_s` seconds, metres
    /// (ignoring its radius). Unbounded with a recognized lap: the lap goes wherever the
    /// tour went, whatever the speed now (0 at the turn-back of an out-and-back).
    pub fn reach_m(&self, dt_s: f64) -> f64 {
        if self.lap.is_some() && dt_s > 0.0 {
            return f64::INFINITY;
        }
        let leg = self
            .leg
            .filter(|_| self.stage != Stage::NoFly)
            .map_or(0.0, |y| {
                geom::dist(self.position_m, y.at(0.0)) + y.reach_m(dt_s)
            });
        if let Some(y) = &self.young
            && self.stage != Stage::NoFly
        {
            // Measured from the model's position, which the fit's may differ from.
            let off = geom::dist(self.position_m, y.at(0.0));
            return (y.reach_m(dt_s) + off).max(leg);
        }
        let v = if self.stage == Stage::NoFly {
            self.nofly_speed_mps
        } else {
            self.replay
                .map_or(self.speed_mps, |r| r.max_speed_mps.max(self.speed_mps))
        };
        (v * dt_s.max(0.0)).max(leg)
    }

    fn levels(&self) -> usize {
        self.bins * LEVELS_PER_BIN
    }

    fn draw_level<R: Rng + ?Sized>(&self, prev_bin: Option<usize>, rng: &mut R) -> usize {
        let r = rng.next_u64();
        let hi = (r >> 32) as u32;
        let lo = r as u32;
        let levels = self.levels() as u64;
        match self.stage {
            Stage::NoFly | Stage::Random => ((u64::from(hi) * levels) >> 32) as usize,
            Stage::Advanced | Stage::Memory => {
                let row = if self.stage == Stage::Memory {
                    prev_bin.map_or(0, |b| self.slice_of_bin[b])
                } else {
                    0
                };
                let cdf = &self.cdf[row.min(self.cdf.len() - 1)];
                let bin = cdf.partition_point(|&c| c < hi).min(self.bins - 1);
                let sub = ((u64::from(lo) * LEVELS_PER_BIN as u64) >> 32) as usize;
                bin * LEVELS_PER_BIN + sub
            }
        }
    }

    /// Samples `n` positions at `t_s + dt_s` (dt counted from the model's start time).
    /// NoFly: uniform over the disc of radius `nofly_speed_mps * dt_s`.
    pub fn sample_future<R: Rng + ?Sized>(
        &self,
        dt_s: f64,
        n: usize,
        rng: &mut R,
    ) -> Vec<[f64; 2]> {
        self.sample_future_with_replay(None, dt_s, n, rng)
    }

    /// As [`MotionModel::sample_future`], replaying the obstacle's own past when the model
    /// says so and `replay` holds its track and frames ([`Propagator::with_replay`]).
    pub fn sample_future_with_replay<R: Rng + ?Sized>(
        &self,
        replay: Option<(&Track, &Manoeuvres)>,
        dt_s: f64,
        n: usize,
        rng: &mut R,
    ) -> Vec<[f64; 2]> {
        if self.stage == Stage::NoFly {
            let r_max = self.reach_m(dt_s);
            return (0..n)
                .map(|_| {
                    let u = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
                    let a =
                        (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * std::f64::consts::TAU;
                    let r = r_max * u.sqrt();
                    [
                        self.position_m[0] + r * a.cos(),
                        self.position_m[1] + r * a.sin(),
                    ]
                })
                .collect();
        }
        let mut p = Propagator::with_replay(self, replay, n, rng);
        p.advance_to(self.t_s + dt_s, rng);
        p.positions().collect()
    }
}

/// Particles of one model, advanced together (struct of arrays).
#[derive(Debug, Clone)]
pub struct Propagator<'a> {
    model: &'a MotionModel,
    /// East coordinates, metres.
    pub x: Vec<f64>,
    /// North coordinates, metres.
    pub y: Vec<f64>,
    ux: Vec<f64>,
    uy: Vec<f64>,
    level: Vec<u16>,
    t_s: f64,
    next_decision_s: f64,
    tables: Vec<(u64, Vec<[f64; 4]>)>,
    replay: Option<ReplayParticles<'a>>,
    /// Each particle's speed, m/s, once it left its young quadratic (empty: the model's).
    speed: Vec<f64>,
    /// Particles still on a young track's quadratic ([`crate::young`]).
    young: Option<YoungParticles>,
    /// The particles of the model's leg ([`MotionModel::leg`]), propagated beside these.
    leg: Option<Box<Propagator<'a>>>,
}

/// Each particle's own quadratic (plus its jerk's cubic term) per axis: coefficients of
/// `1, u, u^2, u^3`, `u` seconds after the model's start.
#[derive(Debug, Clone)]
struct YoungParticles {
    coef: Vec<[[f64; 4]; 2]>,
    centre: [f64; 2],
    model: YoungModel,
    /// When each particle leaves its cubic, seconds after the start.
    until: Vec<f64>,
    /// Particles that left it (flown by the stage model since).
    free: Vec<bool>,
}

impl YoungParticles {
    fn draw<R: Rng + ?Sized>(y: &YoungModel, n: usize, rng: &mut R) -> Self {
        let mut until = Vec::with_capacity(n);
        let coef = (0..n)
            .map(|_| {
                let c = std::array::from_fn(|axis| {
                    let z: [f64; 4] = std::array::from_fn(|_| StandardNormal.sample(&mut *rng));
                    let mut c = y.c[axis];
                    for (r, cr) in c.iter_mut().enumerate() {
                        for (k, zk) in z.iter().take(r + 1).enumerate() {
                            *cr += y.l[r][k] * zk;
                        }
                    }
                    c[3] += y.jerk_sigma_mps3 * z[3] / 6.0;
                    c
                });
                until.push(match y.knot {
                    None => y.until_s,
                    Some(k) => {
                        let e: f64 = rand_distr::Exp1.sample(&mut *rng);
                        (k.min_s + k.mean_s * e).min(y.until_s)
                    }
                });
                c
            })
            .collect();
        Self {
            coef,
            centre: y.at(0.0),
            model: *y,
            free: vec![false; n],
            until,
        }
    }

    /// Particle `i`'s position `u` seconds after the start, within `reach`
    /// ([`YoungModel::reach_m`] at `u`) of the fit's start.
    fn at(&self, i: usize, u: f64, reach: f64) -> [f64; 2] {
        let p: [f64; 2] = std::array::from_fn(|a| {
            let c = self.coef[i][a];
            c[0] + u * (c[1] + u * (c[2] + u * c[3]))
        });
        let (dx, dy) = (p[0] - self.centre[0], p[1] - self.centre[1]);
        let d = dx.hypot(dy);
        if d > reach {
            [
                self.centre[0] + dx * reach / d,
                self.centre[1] + dy * reach / d,
            ]
        } else {
            p
        }
    }

    /// Particle `i`'s velocity `u` seconds after the start.
    fn velocity(&self, i: usize, u: f64) -> [f64; 2] {
        std::array::from_fn(|a| {
            let c = self.coef[i][a];
            c[1] + u * (2.0 * c[2] + u * 3.0 * c[3])
        })
    }
}

impl<'a> Propagator<'a> {
    /// `n` particles at the model's start, each with a first turn drawn for the current
    /// decision interval.
    pub fn new<R: Rng + ?Sized>(model: &'a MotionModel, n: usize, rng: &mut R) -> Self {
        Self::with_replay(model, None, n, rng)
    }

    /// Whether the particles may move although the model's speed is 0: they replay the
    /// obstacle's past, or fly a young track's quadratic (which carries its acceleration).
    pub fn moves(&self) -> bool {
        self.replay.is_some()
            || self.young.is_some()
            || !self.speed.is_empty()
            || self.leg.is_some()
    }

    /// Every particle's position: the model's, then its leg's.
    pub fn positions(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        let own = self.x.iter().zip(&self.y).map(|(&x, &y)| [x, y]);
        let leg = self
            .leg
            .iter()
            .flat_map(|l| l.x.iter().zip(&l.y).map(|(&x, &y)| [x, y]));
        own.chain(leg)
    }

    /// As [`Propagator::new`]; when the model has [`MotionModel::replay`] set and
    /// `replay` holds the obstacle's track and frames with anchors to replay, the particles
    /// replay stretches of its own past ([`crate::replay`]) instead.
    pub fn with_replay<R: Rng + ?Sized>(
        model: &'a MotionModel,
        replay: Option<(&'a Track, &'a Manoeuvres)>,
        n: usize,
        rng: &mut R,
    ) -> Self {
        let k = model
            .leg
            .map_or(0, |l| ((l.share * n as f64).round() as usize).min(n));
        let mut p = Self::own(model, replay, n - k, rng);
        if let Some(l) = model.leg.filter(|_| k > 0) {
            let l = YoungModel { share: 1.0, ..l };
            p.leg = Some(Box::new(Self::stage(model, Some(&l), k, rng)));
        }
        p
    }

    /// The model's own particles (replay, or the stage model with its young quadratic).
    fn own<R: Rng + ?Sized>(
        model: &'a MotionModel,
        replay: Option<(&'a Track, &'a Manoeuvres)>,
        n: usize,
        rng: &mut R,
    ) -> Self {
        if let (Some(rm), Some((track, man))) = (model.replay, replay)
            && let Some(rp) = ReplayParticles::new(
                track,
                man,
                &rm.cfg,
                Novel {
                    speed_mps: model.speed_mps,
                    w_max_radps: model.turn_limit_radps,
                    decision_interval_s: model.decision_interval_s,
                },
                n,
                rng,
            )
        {
            return Self {
                model,
                x: vec![model.position_m[0]; n],
                y: vec![model.position_m[1]; n],
                ux: Vec::new(),
                uy: Vec::new(),
                level: Vec::new(),
                t_s: model.t_s,
                next_decision_s: f64::INFINITY,
                tables: Vec::new(),
                replay: Some(rp),
                speed: Vec::new(),
                young: None,
                leg: None,
            };
        }
        Self::stage(model, model.young.as_ref(), n, rng)
    }

    /// `n` particles of the stage model, `young`'s share of them on its polynomial first.
    fn stage<R: Rng + ?Sized>(
        model: &'a MotionModel,
        young: Option<&YoungModel>,
        n: usize,
        rng: &mut R,
    ) -> Self {
        let dti = model.decision_interval_s;
        let level = (0..n)
            .map(|_| model.draw_level(model.last_bin, rng) as u16)
            .collect();
        // Start-state uncertainty: observation noise and fit error in the position, the
        // heading's fit error (so the 95% region covers the truth at +1 s too).
        let (mut x, mut y) = (vec![model.position_m[0]; n], vec![model.position_m[1]; n]);
        let (mut ux, mut uy) = (vec![0.0; n], vec![0.0; n]);
        let (sp, sh) = (model.start_position_sigma_m, model.start_heading_sigma_rad);
        for i in 0..n {
            let mut h = model.heading_rad;
            if sp > 0.0 || sh > 0.0 {
                let z: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(&mut *rng));
                x[i] += sp * z[0];
                y[i] += sp * z[1];
                h += sh * z[2];
            }
            (uy[i], ux[i]) = h.sin_cos();
        }
        let young = young.map(|ym| {
            let k = ((ym.share * n as f64).round() as usize).min(n);
            let yp = YoungParticles::draw(ym, k, rng);
            let reach = ym.reach_m(0.0);
            for i in 0..k {
                [x[i], y[i]] = yp.at(i, 0.0, reach);
            }
            yp
        });
        let speed = if young.is_some() {
            vec![model.speed_mps; n]
        } else {
            Vec::new()
        };
        Self {
            model,
            x,
            y,
            ux,
            uy,
            level,
            t_s: model.t_s,
            next_decision_s: ((model.t_s / dti).floor() + 1.0) * dti,
            tables: Vec::new(),
            replay: None,
            speed,
            young,
            leg: None,
        }
    }

    /// Current time of the particles, seconds.
    pub fn t_s(&self) -> f64 {
        self.t_s
    }

    fn table(&mut self, h: f64) -> usize {
        let key = h.to_bits();
        if let Some(i) = self.tables.iter().position(|(k, _)| *k == key) {
            return i;
        }
        let m = self.model;
        let levels = m.levels();
        let width = 2.0 * m.w_max_radps / levels as f64;
        let tab = (0..levels)
            .map(|j| {
                let w = (m.turn_bias_radps - m.w_max_radps + (j as f64 + 0.5) * width)
                    .clamp(-m.turn_limit_radps, m.turn_limit_radps);
                let th = w * h;
                let (s, c) = th.sin_cos();
                let (a, b) = if w.abs() > 1e-9 {
                    (s / w, (1.0 - c) / w)
                } else {
                    (h, 0.5 * w * h * h)
                };
                [c, s, a, b]
            })
            .collect();
        if self.tables.len() >= 4 {
            self.tables.remove(0);
        }
        self.tables.push((key, tab));
        self.tables.len() - 1
    }

    /// Advances every particle to `t_s` (no-op if already there or later).
    pub fn advance_to<R: Rng + ?Sized>(&mut self, t_s: f64, rng: &mut R) {
        if let Some(l) = &mut self.leg {
            l.advance_to(t_s, rng);
        }
        if let Some(rp) = &mut self.replay {
            if t_s > self.t_s {
                rp.advance_to(t_s - self.model.t_s, &mut self.x, &mut self.y, rng);
                self.t_s = t_s;
            }
            return;
        }
        let t_s = t_s.max(self.t_s);
        if let Some(mut yp) = self.young.take_if(|y| y.model.knot.is_some()) {
            // Each particle leaves its leg's cubic at its own knot: from there it flies on
            // straight for the rest of this step, then as the stage model does.
            let m = self.model;
            self.step(t_s, rng);
            let u = t_s - m.t_s;
            let mut on_cubic = false;
            for i in 0..yp.coef.len() {
                if yp.free[i] {
                    continue;
                }
                let e = yp.until[i];
                if u <= e {
                    [self.x[i], self.y[i]] = yp.at(i, u, yp.model.reach_m(u));
                    on_cubic = true;
                    continue;
                }
                let p = yp.at(i, e, yp.model.reach_m(e));
                let v = yp.velocity(i, e);
                let sp = v[0].hypot(v[1]);
                let vs = sp.min(yp.model.max_speed_mps);
                self.speed[i] = vs;
                if sp > 1e-9 {
                    (self.ux[i], self.uy[i]) = (v[0] / sp, v[1] / sp);
                }
                let d = vs * (u - e);
                self.x[i] = p[0] + self.ux[i] * d;
                self.y[i] = p[1] + self.uy[i] * d;
                yp.free[i] = true;
            }
            if on_cubic {
                self.young = Some(yp);
            }
            return;
        }
        if let Some(yp) = self.young.take() {
            let m = self.model;
            let t_end = m.t_s + yp.model.until_s;
            if t_s <= t_end {
                self.step(t_s, rng);
                let reach = yp.model.reach_m(t_s - m.t_s);
                for i in 0..yp.coef.len() {
                    [self.x[i], self.y[i]] = yp.at(i, t_s - m.t_s, reach);
                }
                self.young = Some(yp);
                return;
            }
            // The quadratic ends: each of its particles flies on at its own speed and
            // heading.
            self.step(t_end, rng);
            let e = yp.model.until_s;
            let reach = yp.model.reach_m(e);
            for i in 0..yp.coef.len() {
                [self.x[i], self.y[i]] = yp.at(i, e, reach);
                let v = yp.velocity(i, e);
                let sp = v[0].hypot(v[1]);
                self.speed[i] = sp.min(yp.model.max_speed_mps);
                if sp > 1e-9 {
                    (self.ux[i], self.uy[i]) = (v[0] / sp, v[1] / sp);
                }
            }
        }
        self.step(t_s, rng);
    }

    /// Advances the stage model's particles (turns drawn every decision interval).
    fn step<R: Rng + ?Sized>(&mut self, t_s: f64, rng: &mut R) {
        if self.model.speed_mps <= 0.0 && self.speed.is_empty() {
            self.t_s = self.t_s.max(t_s);
            return;
        }
        while self.t_s < t_s - 1e-9 {
            let t_next = t_s.min(self.next_decision_s);
            let h = t_next - self.t_s;
            // Round the step so that repeated steps of one length share a table.
            let h = (h * 1e9).round() / 1e9;
            let ti = self.table(h);
            let tab = &self.tables[ti].1;
            let v0 = self.model.speed_mps;
            for i in 0..self.x.len() {
                let [c, s, a, b] = tab[self.level[i] as usize];
                let v = self.speed.get(i).copied().unwrap_or(v0);
                let (a, b) = (a * v, b * v);
                let (ux, uy) = (self.ux[i], self.uy[i]);
                self.x[i] += a * ux - b * uy;
                self.y[i] += a * uy + b * ux;
                self.ux[i] = c * ux - s * uy;
                self.uy[i] = s * ux + c * uy;
            }
            self.t_s = t_next;
            if self.t_s >= self.next_decision_s - 1e-9 {
                self.next_decision_s += self.model.decision_interval_s;
                for i in 0..self.level.len() {
                    let prev_bin = self.level[i] as usize / LEVELS_PER_BIN;
                    self.level[i] = self.model.draw_level(Some(prev_bin), rng) as u16;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn est(speed: f64) -> Estimates {
        Estimates {
            t_s: 10.0,
            position_m: [0.0, 0.0],
            velocity_mps: [speed, 0.0],
            speed_mps: speed,
            heading_deg: Some(90.0),
            min_turn_radius_m: None,
            turn_rate_max_dps: 5.0,
            turn_rate_dps: None,
            mean_turn_rate_dps: None,
        }
    }

    /// The default stages with every particle starting exactly at the estimate.
    fn exact_start() -> StageConfig {
        StageConfig {
            start_position_sigma_m: 0.0,
            start_heading_sigma_rad: 0.0,
            ..StageConfig::default()
        }
    }

    #[test]
    fn particles_fly_at_constant_speed_within_the_reachable_disc() {
        let cfg = exact_start();
        let hist = TurnHistogram::build(&[], 0.3, &cfg);
        let m = MotionModel::new(Stage::Random, &est(10.0), &hist, 1.0, 25.0, &cfg);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let pts = m.sample_future(5.0, 200, &mut rng);
        for p in &pts {
            // Arc length 50 m: the chord is at most 50 m and (max turn 0.3 rad/s over 5 s
            // = 1.5 rad, chord of a 1.5 rad arc of length 50 = 2 R sin(0.75), R = 33.3)
            // at least 45.4 m.
            let d = p[0].hypot(p[1]);
            assert!((45.0..=50.0 + 1e-9).contains(&d), "{d}");
        }
    }

    #[test]
    fn a_straight_histogram_predicts_a_straight_line() {
        let cfg = exact_start();
        let mut hist = TurnHistogram::build(&[], 0.1, &cfg);
        hist.counts = vec![0, 0, 0, 0, 1000, 0, 0, 0, 0];
        let m = MotionModel::new(Stage::Advanced, &est(10.0), &hist, 1.0, 25.0, &cfg);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let pts = m.sample_future(10.0, 500, &mut rng);
        let near = pts
            .iter()
            .filter(|p| (p[0] - 100.0).abs() < 2.0 && p[1].abs() < 6.0)
            .count();
        // Smoothing leaves 4 / 1004.5 mass outside the centre bin; nearly all stay close.
        assert!(near >= 480, "{near}");
    }
}
