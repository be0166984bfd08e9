//! Monte Carlo recursive bisection between two immovable points (seed 002, "Pathfinding
//! algorithm"; DESIGN.md "Planner", steps 1-4).
//!
//! For a leg `A -> B` flown from time `t_A`:
//! 1. five turning choices `C_k = M + k * delta * n`, `k = -2..=2`, on the perpendicular
//!    bisector of `AB` (`M` the midpoint, `n` the left normal). `delta` is scaled to what
//!    is in the way: the offset at `C` that clears the cylinders blocking the leg and the
//!    highest dynamic risk found along it (probed on the aircraft's clock, then across
//!    the leg there), at least 5% of the leg; 20% of the leg when nothing measurable is in
//!    the way. Choices outside the fly zone are discarded.
//! 2. For each choice, `S` sampled paths `A -> C -> B` of equidistant points (`n` per half),
//!    each interior point pushed along the half's normal by a normal deviate
//!    `sigma * z`, `z ~ N(0, 1)` clamped to `[-2, 2]`, tapered by `sin(pi i / n)` so the
//!    ends stay put. `sigma = delta / 4`: the samples of one choice sweep up to half the way
//!    to the neighbouring choices, so a choice scores well only when the region around it
//!    is safe too (seed 002's robustness argument). Sampled paths may bend tighter than the
//!    aircraft can; the chosen path is simplified, and every returned route is flown
//!    forward at the turn radius and checked ([`crate::verify`]).
//! 3. A sample's score is `sum risk(p_i, t_i) * ds_i` (exposure, read at most
//!    [`MAX_READ_SPACING_M`] apart so that the smallest sphere cannot fall between two
//!    reads; `t_i` the arrival time at constant speed, zero past the horizon) plus hard
//!    penalties (a segment in a cylinder's
//!    buffer or out of the fly zone; a turn at `C` too sharp for `R`) plus a small length
//!    weight. A choice's score is the mean over its samples (robustness).
//! 4. The best choice is kept; `A -> C` and `C -> B` are searched the same way, down to
//!    the depth limit or the resolution; at the bottom the best sample of the winning
//!    choice becomes the path.
//!
//! Budget: a (sub-)leg without threat (`segment_risk_bound` below `threat_epsilon` and no
//! blocking cylinder) is returned straight at once; the sample count grows with the leg's
//! variability (a hint in `[0, 1]`, or the segment risk bound when absent) from `samples`
//! to `max_samples`; a [`Termination`] (deadline or cancel flag) stops the search (anytime: what has been decided is kept,
//! the rest stays straight) and is checked before each choice is sampled. A choice stops
//! sampling as soon as it cannot beat the best mean so far: every term of a sample's score
//! is non-negative and a sampled path runs through `A`, `C` and `B`, so its running sum plus
//! the length term of `A -> C -> B` (and the turn cost) for each sample still to draw is a
//! lower bound of its final sum. The choice made is the same with or without pruning.
//!
//! Determinism: all randomness comes from the caller's generator, consumed in a fixed
//! order; each choice of a node draws from a generator of its own seeded from it, so how
//! far a pruned choice sampled changes nothing after it. Buffers live in a reusable [`Workspace`]; the hot loop does not allocate.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::cost::LegEnv;
use crate::geometry::{
    Point, add, dist, dist_point_segment, lerp, norm, perp, scale, sub, turn_angle_rad, unit,
};
use crate::mission::Cylinder;
use crate::termination::Termination;
use crate::turn::fillet_tangent_m;

/// Number of turning choices per bisection (seed 002: five).
pub const CHOICES: usize = 5;

/// The order the choices are sampled in: straight first, then outwards (see the pruning
/// in `node`).
const CHOICE_ORDER: [usize; CHOICES] = [2, 1, 3, 0, 4];

/// Probe points along a leg (and across it) when sizing the choices.
const PROBES: usize = 16;

/// Largest spacing of risk reads along a sampled path, metres (below the 9.1 m radius of
/// the smallest 30 ft sphere plus the map's buffer, twice).
pub const MAX_READ_SPACING_M: f64 = 20.0;

/// Bisection parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BisectionParams {
    /// Sampled paths per choice for a calm leg. Default 12.
    pub samples: usize,
    /// Sampled paths per choice for the most variable leg. Default 32.
    pub max_samples: usize,
    /// Maximum recursion depth (1 = one bisection). Default 3.
    pub max_depth: u32,
    /// Stop bisecting when a half would be shorter than this, metres. Default 60.
    pub resolution_m: f64,
    /// Points per half of a sampled path. Default 8.
    pub points_per_half: usize,
    /// Score per metre of path length (in metres of exposure). Default 0.05.
    pub length_weight: f64,
    /// Score of one hard violation (cylinder buffer, fly zone). Default 10 000.
    pub hard_penalty: f64,
    /// Score of a turn at a choice too sharp for the turn radius. Default 200.
    pub turn_penalty: f64,
    /// Legs whose risk bound is below this are not searched. Default 1e-3.
    pub threat_epsilon: f64,
}

impl Default for BisectionParams {
    fn default() -> Self {
        Self {
            samples: 12,
            max_samples: 32,
            max_depth: 3,
            resolution_m: 60.0,
            points_per_half: 8,
            length_weight: 0.05,
            hard_penalty: 10_000.0,
            turn_penalty: 200.0,
            threat_epsilon: 1e-3,
        }
    }
}

impl BisectionParams {
    /// Sets the base sample count.
    pub fn samples(mut self, s: usize) -> Self {
        self.samples = s.max(1);
        self.max_samples = self.max_samples.max(self.samples);
        self
    }
    /// Sets the depth limit.
    pub fn max_depth(mut self, d: u32) -> Self {
        self.max_depth = d.max(1);
        self
    }
    /// Sets the resolution, metres.
    pub fn resolution_m(mut self, r: f64) -> Self {
        self.resolution_m = r;
        self
    }
}

/// Reusable buffers for [`bisect_leg`].
#[derive(Debug, Default)]
pub struct Workspace {
    sample: Vec<Point>,
    best: [Vec<Point>; CHOICES],
    near: Vec<(Point, f64)>,
    /// `sin(pi i / np)` for `i` in `1..np`, the perturbation's envelope along a half
    /// ([`sample_path`]), kept for the `np` it was made for: one `sin` per point of every
    /// sample path was a sixth of a plan's time on the bench.
    envelope: Vec<f64>,
    /// Sample every choice in full (the test that shows pruning changes nothing).
    no_prune: bool,
}

/// Result of searching one leg.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LegSearch {
    /// Points strictly between `A` and `B`, in flight order (empty = straight).
    pub points: Vec<Point>,
    /// Whether any threat was found (false = returned straight at once).
    pub searched: bool,
    /// Whether the deadline cut the search short.
    pub timed_out: bool,
    /// Risk-field evaluations spent.
    pub evaluations: u64,
}

struct Ctx<'a, 'e, R: Rng + ?Sized> {
    env: &'a LegEnv<'e>,
    params: &'a BisectionParams,
    turn_radius_m: f64,
    samples: usize,
    term: &'a Termination,
    rng: &'a mut R,
    ws: &'a mut Workspace,
    out: LegSearch,
}

/// Searches the leg `a -> b` flown from `t_a_s` (see the module docs). `variability` in
/// `[0, 1]` scales the sample budget; `None` derives it from the risk field.
pub fn bisect_leg<R: Rng + ?Sized>(
    env: &LegEnv<'_>,
    a: Point,
    b: Point,
    t_a_s: f64,
    turn_radius_m: f64,
    params: &BisectionParams,
    variability: Option<f64>,
    term: &Termination,
    rng: &mut R,
    ws: &mut Workspace,
) -> LegSearch {
    let bound = threat(env, a, b, t_a_s);
    let blocked = blocking_cylinder(env, a, b).is_some();
    if bound < params.threat_epsilon && !blocked {
        return LegSearch::default();
    }
    let v = variability.unwrap_or(bound).clamp(0.0, 1.0);
    let samples = params.samples
        + ((params.max_samples.saturating_sub(params.samples)) as f64 * v).round() as usize;
    let mut ctx = Ctx {
        env,
        params,
        turn_radius_m,
        samples: samples.max(1),
        term,
        rng,
        ws,
        out: LegSearch {
            searched: true,
            evaluations: 17,
            ..LegSearch::default()
        },
    };
    node(&mut ctx, a, b, t_a_s, 1);
    ctx.out
}

/// Conservative dynamic risk bound of the straight segment within the horizon.
fn threat(env: &LegEnv<'_>, a: Point, b: Point, t_a_s: f64) -> f64 {
    if t_a_s > env.horizon_end_s {
        return 0.0;
    }
    let l = dist(a, b);
    let t_b = (t_a_s + l / env.speed_mps).min(env.horizon_end_s);
    let f = ((t_b - t_a_s) * env.speed_mps / l.max(1e-9)).clamp(0.0, 1.0);
    env.segment_risk_bound(a, lerp(a, b, f), t_a_s, t_b)
}

fn blocking_cylinder<'c>(env: &'c LegEnv<'_>, a: Point, b: Point) -> Option<&'c Cylinder> {
    env.cylinders.iter().find(|c| {
        c.matters_at(env.alt_m)
            && dist_point_segment(c.center_m, a, b)
                < c.radius_m * (1.0 + env.buffer_fraction) - 1e-9
    })
}

fn timed_out<R: Rng + ?Sized>(ctx: &mut Ctx<'_, '_, R>) -> bool {
    if ctx.term.should_stop() {
        ctx.out.timed_out = true;
        return true;
    }
    false
}

/// Searches `a -> b`, appending the interior points (excluding both ends) to `ctx.out`.
fn node<R: Rng + ?Sized>(ctx: &mut Ctx<'_, '_, R>, a: Point, b: Point, t_a: f64, depth: u32) {
    let env = *ctx.env;
    let params = *ctx.params;
    let l = dist(a, b);
    let Some(u) = unit(sub(b, a)) else { return };
    if depth > 1 {
        ctx.out.evaluations += 17;
        if threat(&env, a, b, t_a) < params.threat_epsilon
            && blocking_cylinder(&env, a, b).is_none()
        {
            return;
        }
    }
    if timed_out(ctx) {
        return;
    }
    let n = perp(u);
    let m = lerp(a, b, 0.5);

    // Choice spacing, scaled to what is in the way: the offset at C that the path
    // A -> C -> B needs to clear each obstacle. A point at fraction f of the leg moves by
    // offset_C * min(f, 1 - f) / 0.5, so an obstacle near an end needs a larger offset
    // at C (capped by taking f >= 0.1). The +-1 choices get that offset, the +-2 choices
    // twice it; with nothing measurable in the way, 20% of the leg.
    let gain = |f: f64| 0.5 / f.min(1.0 - f).max(0.1);
    let mut need: f64 = 0.0;
    for c in env.cylinders.iter().filter(|c| c.matters_at(env.alt_m)) {
        let d_line = dist_point_segment(c.center_m, a, b);
        if d_line < c.radius_m * (1.0 + env.buffer_fraction) {
            let rb2 = c.radius_m * (1.0 + 2.0 * env.buffer_fraction);
            let f = crate::geometry::closest_t_on_segment(c.center_m, a, b);
            need = need.max((rb2 + d_line) * gain(f));
        }
    }
    if t_a <= env.horizon_end_s {
        // Where along the leg (on the aircraft's clock) is the risk highest?
        let (mut peak, mut f_peak) = (0.0, 0.5);
        for j in 1..PROBES {
            let f = j as f64 / PROBES as f64;
            let t = t_a + f * l / env.speed_mps;
            if t > env.horizon_end_s {
                break;
            }
            let r = env.risk_at(lerp(a, b, f), t);
            ctx.out.evaluations += 1;
            if r > peak {
                (peak, f_peak) = (r, f);
            }
        }
        if peak >= params.threat_epsilon {
            let p = lerp(a, b, f_peak);
            let t = t_a + f_peak * l / env.speed_mps;
            let mut clear_at = l;
            for j in 1..=PROBES {
                let o = l * j as f64 / PROBES as f64;
                let rl = env.risk_at(add(p, scale(n, o)), t);
                let rr = env.risk_at(add(p, scale(n, -o)), t);
                ctx.out.evaluations += 2;
                if rl.min(rr) <= 0.1 * peak {
                    clear_at = o;
                    break;
                }
            }
            need = need.max(clear_at * gain(f_peak));
        }
    }
    let delta = if need > 0.0 {
        need.max(0.05 * l)
    } else {
        0.2 * l
    }
    .min(l);

    let half = 0.5 * l;
    let np = params.points_per_half.max(2);
    let sigma = delta / 4.0;

    let mut scores = [f64::INFINITY; CHOICES];
    let mut best_sample = [f64::INFINITY; CHOICES];
    let mut any = false;
    // The lowest mean score so far: every term of a sample's score is non-negative, so a
    // choice whose running sum already exceeds it times the sample count cannot win and
    // stops sampling (exact pruning; the straight choice first, then outwards).
    let mut best_mean = f64::INFINITY;
    // Each choice samples from a generator of its own, seeded from the leg's generator
    // in a fixed order: how many samples a pruned choice drew does not change the samples
    // of the next, so pruning never changes the choice made.
    let choice_seeds: [u64; CHOICES] = std::array::from_fn(|_| ctx.rng.next_u64());
    for k in CHOICE_ORDER {
        let c = add(m, scale(n, (k as f64 - 2.0) * delta));
        if !env.zones.contains(c) {
            continue;
        }
        if timed_out(ctx) {
            break;
        }
        let (ac, cb) = (dist(a, c), dist(c, b));
        // Turn at C with straight halves: each half may spend half its length on it.
        let turn_cost = if ctx.turn_radius_m > 0.0
            && fillet_tangent_m(turn_angle_rad(a, c, b), ctx.turn_radius_m) > 0.5 * ac.min(cb)
        {
            params.turn_penalty
        } else {
            0.0
        };
        // Obstacles near this choice's corridor (deviation up to 2 sigma).
        ctx.ws.near.clear();
        for cyl in env.cylinders.iter().filter(|q| q.matters_at(env.alt_m)) {
            let rb = cyl.radius_m * (1.0 + env.buffer_fraction);
            let d =
                dist_point_segment(cyl.center_m, a, c).min(dist_point_segment(cyl.center_m, c, b));
            if d < rb + 2.0 * sigma + 1e-6 {
                ctx.ws.near.push((cyl.center_m, rb));
            }
        }
        let zone_safe = env.zones.is_unbounded()
            || env.zones.polygons().iter().any(|p| {
                p.contains_segment(a, c)
                    && p.contains_segment(c, b)
                    && segment_boundary_distance(p, a, c).min(segment_boundary_distance(p, c, b))
                        > 2.0 * sigma + 1e-6
            });
        let mut sum = 0.0;
        let cutoff = if !ctx.ws.no_prune {
            best_mean * ctx.samples as f64 + 1e-9
        } else {
            f64::INFINITY
        };
        let mut pruned = false;
        // Every sampled path runs through A, C and B, so a sample scores at least the
        // length term of A -> C -> B plus the turn cost (exposure and hard violations are
        // non-negative): a choice whose samples still to draw cannot bring its mean under
        // the best is stopped before drawing them, and one that never could is not sampled.
        let floor = (params.length_weight * (ac + cb) + turn_cost) * (1.0 - 1e-9);
        let mut rng = ChaCha8Rng::seed_from_u64(choice_seeds[k]);
        for j in 0..ctx.samples {
            if sum + (ctx.samples - j) as f64 * floor > cutoff {
                pruned = true;
                break;
            }
            sample_path(ctx.ws, &mut rng, a, c, b, sigma, np);
            let s = score_sample(ctx, t_a, zone_safe) + turn_cost;
            sum += s;
            if s < best_sample[k] {
                best_sample[k] = s;
                let Ctx { ws, .. } = ctx;
                ws.best[k].clear();
                ws.best[k].extend_from_slice(&ws.sample);
            }
            if sum > cutoff {
                pruned = true;
                break;
            }
        }
        if !pruned {
            scores[k] = sum / ctx.samples as f64;
            best_mean = best_mean.min(scores[k]);
        }
        any = true;
    }
    if !any {
        return;
    }
    let mut kbest = 2;
    for k in 0..CHOICES {
        // Ties go to the middle (straight) choice, then to the lower index.
        if scores[k] < scores[kbest] - 1e-12 {
            kbest = k;
        }
    }
    if !scores[kbest].is_finite() {
        return;
    }
    let c = add(m, scale(n, (kbest as f64 - 2.0) * delta));
    let bottom = depth >= params.max_depth || half < params.resolution_m || ctx.out.timed_out;
    if bottom {
        let pts = &ctx.ws.best[kbest];
        // Interior points: drop A (first) and B (last).
        let interior = &pts[1..pts.len() - 1];
        ctx.out.points.extend_from_slice(interior);
        return;
    }
    let t_c = t_a + dist(a, c) / env.speed_mps;
    node(ctx, a, c, t_a, depth + 1);
    ctx.out.points.push(c);
    node(ctx, c, b, t_c, depth + 1);
}

/// Fills `ws.sample` with `A, (np-1 points), C, (np-1 points), B`.
fn sample_path(
    ws: &mut Workspace,
    rng: &mut ChaCha8Rng,
    a: Point,
    c: Point,
    b: Point,
    sigma: f64,
    np: usize,
) {
    if ws.envelope.len() != np - 1 {
        ws.envelope.clear();
        ws.envelope.extend((1..np).map(|i| {
            let f = i as f64 / np as f64;
            (std::f64::consts::PI * f).sin()
        }));
    }
    ws.sample.clear();
    ws.sample.push(a);
    for (p, q) in [(a, c), (c, b)] {
        let d = sub(q, p);
        let len = norm(d);
        let nn = if len > 1e-12 {
            perp(scale(d, 1.0 / len))
        } else {
            [0.0, 0.0]
        };
        for i in 1..np {
            let f = i as f64 / np as f64;
            let z: f64 = StandardNormal.sample(rng);
            let y = ws.envelope[i - 1] * z.clamp(-2.0, 2.0) * sigma;
            ws.sample.push(add(lerp(p, q, f), scale(nn, y)));
        }
        ws.sample.push(q);
    }
}

fn score_sample<R: Rng + ?Sized>(ctx: &mut Ctx<'_, '_, R>, t_a: f64, zone_safe: bool) -> f64 {
    let env = ctx.env;
    let params = ctx.params;
    let pts = &ctx.ws.sample;
    let mut t = t_a;
    let mut exposure = 0.0;
    let mut length = 0.0;
    let mut hard = 0usize;
    let mut evals = 0u64;
    for w in pts.windows(2) {
        let (p, q) = (w[0], w[1]);
        let l = dist(p, q);
        length += l;
        let n = ceil_count(l / MAX_READ_SPACING_M);
        let ds = l / n as f64;
        for i in 1..=n {
            let ti = t + i as f64 * ds / env.speed_mps;
            if ti > env.horizon_end_s {
                break;
            }
            exposure += env.risk_at(lerp(p, q, i as f64 / n as f64), ti) * ds;
            evals += 1;
        }
        t += l / env.speed_mps;
        for &(cc, rb) in &ctx.ws.near {
            if dist_point_segment(cc, p, q) < rb {
                hard += 1;
            }
        }
        if !zone_safe && !env.zones.contains_segment(p, q) {
            hard += 1;
        }
    }
    ctx.out.evaluations += evals;
    exposure + params.length_weight * length + params.hard_penalty * hard as f64
}

/// `x.ceil().max(1.0) as usize` for the non-negative `x` of a segment's reads (NaN gives 1,
/// as there), without libm's `ceil` call: it runs for every segment of every sample path.
#[inline]
fn ceil_count(x: f64) -> usize {
    let n = x as usize;
    let n = if (n as f64) < x {
        n.saturating_add(1)
    } else {
        n
    };
    n.max(1)
}

/// Distance from segment `a -> b` (not crossing the boundary) to the polygon boundary.
fn segment_boundary_distance(p: &crate::geometry::Polygon, a: Point, b: Point) -> f64 {
    let v = p.vertices();
    let mut d = p.boundary_distance(a).min(p.boundary_distance(b));
    for &q in v {
        d = d.min(dist_point_segment(q, a, b));
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ceil_count_is_the_ceiling_of_the_reads_at_least_one() {
        let mut x: f64 = 0.0;
        while x < 500.0 {
            for v in [x, x + 1e-12, x - 1e-12, x + 0.5] {
                let v = v.max(0.0);
                assert_eq!(ceil_count(v), v.ceil().max(1.0) as usize, "{v}");
            }
            x += 0.37;
        }
        for v in [0.0, 1.0, 2.0, 1e6, 1e15 + 0.5, f64::NAN] {
            assert_eq!(ceil_count(v), v.ceil().max(1.0) as usize, "{v}");
        }
    }
    use crate::mission::Zones;
    use predictor::RiskField;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A static disc of risk 1 (radius 40 m) at (500, 0).
    struct Disc;
    impl RiskField for Disc {
        fn risk(&self, p: [f64; 2], _t: f64) -> f64 {
            if dist(p, [500.0, 0.0]) < 40.0 {
                1.0
            } else {
                0.0
            }
        }
    }

    fn env<'a>(risk: &'a dyn RiskField, zones: &'a Zones) -> LegEnv<'a> {
        LegEnv {
            risk,
            zones,
            cylinders: &[],
            alt_m: 50.0,
            band_m: crate::cost::ALL_ALTITUDES,
            band_hint: predictor::NO_BAND_HINT,
            buffer_fraction: 0.2,
            speed_mps: 20.0,
            horizon_end_s: 1e9,
        }
    }

    /// Searches the leg (0, 0) -> (1000, 0) from t = 0 at a 40 m turn radius.
    fn search(e: &LegEnv<'_>, seed: u64) -> LegSearch {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        bisect_leg(
            e,
            [0.0, 0.0],
            [1000.0, 0.0],
            0.0,
            40.0,
            &BisectionParams::default(),
            None,
            &Termination::default(),
            &mut rng,
            &mut Workspace::default(),
        )
    }

    #[test]
    fn a_calm_leg_is_returned_straight_without_search() {
        let zones = Zones::default();
        let e = env(&predictor::field::NoRisk, &zones);
        let r = search(&e, 1);
        assert!(r.points.is_empty() && !r.searched);
    }

    #[test]
    fn a_disc_on_the_leg_is_avoided() {
        let zones = Zones::default();
        let e = env(&Disc, &zones);
        let r = search(&e, 7);
        assert!(r.searched && !r.points.is_empty());
        let mut pts = vec![[0.0, 0.0]];
        pts.extend(&r.points);
        pts.push([1000.0, 0.0]);
        let risk = e.path_risk(&pts, 0.0, 2.0);
        assert_eq!(risk.peak, 0.0, "{pts:?}");
    }

    #[test]
    fn the_same_seed_gives_the_same_points() {
        let zones = Zones::default();
        let e = env(&Disc, &zones);
        let run = |seed| search(&e, seed).points;
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
    }

    /// Discs of risk `level` moving at constant velocity: `(x, y, vx, vy, radius, level)`.
    struct Movers(Vec<(f64, f64, f64, f64, f64, f64)>);
    impl RiskField for Movers {
        fn risk(&self, p: [f64; 2], t: f64) -> f64 {
            let mut free = 1.0;
            for &(x, y, vx, vy, r, level) in &self.0 {
                if dist(p, [x + vx * t, y + vy * t]) < r {
                    free *= 1.0 - level;
                }
            }
            1.0 - free
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// Pruning (a choice stopped once its samples still to draw cannot bring its mean
        /// under the best, by the running sum or by the length of A -> C -> B) changes no
        /// point of the search: each choice samples from its own generator.
        #[test]
        fn pruning_choices_that_cannot_win_changes_no_point(
            movers in proptest::collection::vec(
                (0.0..1000.0f64, -300.0..300.0f64, -20.0..20.0f64, -20.0..20.0f64, 20.0..150.0f64, 0.05..1.0f64),
                1..6,
            ),
            cyl in proptest::collection::vec((100.0..900.0f64, -200.0..200.0f64, 10.0..80.0f64), 0..3),
            end in (600.0..1400.0f64, -300.0..300.0f64),
            seed in 0u64..1000,
            turn in 0.0..80.0f64,
            zoned in proptest::bool::ANY,
        ) {
            let field = Movers(movers);
            let cylinders: Vec<Cylinder> = cyl
                .iter()
                .map(|&(x, y, r)| Cylinder { center_m: [x, y], radius_m: r, top_m: 500.0 })
                .collect();
            let zones = if zoned {
                Zones::single(&[[-200.0, -450.0], [1600.0, -450.0], [1600.0, 450.0], [-200.0, 450.0]])
            } else {
                Zones::default()
            };
            let e = LegEnv { cylinders: &cylinders, ..env(&field, &zones) };
            let run = |prune: bool| {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                bisect_leg(
                    &e,
                    [0.0, 0.0],
                    [end.0, end.1],
                    0.0,
                    turn,
                    &BisectionParams::default(),
                    None,
                    &Termination::default(),
                    &mut rng,
                    &mut Workspace { no_prune: !prune, ..Workspace::default() },
                )
            };
            let (pruned, full) = (run(true), run(false));
            proptest::prop_assert_eq!(&pruned.points, &full.points);
            proptest::prop_assert!(pruned.evaluations <= full.evaluations);
        }
    }
}
