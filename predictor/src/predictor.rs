//! The multi-obstacle predictor (seed 002, "Obstacle characterization"): one track,
//! estimator set and stage machine per moving obstacle, keyed by its id, and a cached risk
//! map updated incrementally when observations arrive.
//!
//! # Example
//! ```
//! use predictor::{Observation, ObserveOutcome, Predictor, PredictorConfig, RiskField, RiskMapConfig, Stage};
//! let mut p = Predictor::new(PredictorConfig::default());
//! for i in 0..40 {
//!     let t_s = f64::from(i) * 0.1;
//!     let o = Observation { t_s, p_m: [10.0 * t_s, 0.0], alt_m: 50.0, radius_m: 10.0 };
//!     assert_eq!(p.observe("0", o), ObserveOutcome::Accepted);
//! }
//! let s = p.obstacles().next().unwrap();
//! assert_eq!(s.stage, Stage::Random);
//! assert!((s.estimates.speed_mps - 10.0).abs() < 1e-6);
//! assert_eq!(s.estimates.heading_deg.map(f64::round), Some(90.0)); // compass: east
//! let map = p.risk_map(&RiskMapConfig::default().bounds([-200.0, -200.0], [200.0, 200.0]), &[], 3.9);
//! assert!(map.risk([39.0, 0.0], 3.9) > 0.99); // at the obstacle now
//! assert_eq!(map.risk([-150.0, 150.0], 3.9), 0.0);
//! ```

use crate::estimate::{self, Estimates, EstimatorConfig, TurnSampler, TurnSummary};
use crate::field::RiskField;
use crate::motion::{MotionModel, ReplayModel};
use crate::periodic::{Lap, LapKind, PeriodicConfig, find_lap};
use crate::replay::{Manoeuvres, ReplayConfig};
use crate::risk_map::{ObstacleInput, RiskMap, RiskMapConfig};
use crate::stage::{Characterizer, Stage, StageChange, StageConfig, TurnHistogram};
use crate::track::{Observation, ObserveOutcome, Track};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use std::collections::{BTreeMap, BTreeSet};

/// 40 knots, the rules' maximum moving-obstacle speed, in m/s.
pub const RULES_MAX_OBSTACLE_SPEED_MPS: f64 = 40.0 * 0.514_444;

/// Predictor parameters, with documented defaults.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PredictorConfig {
    /// Largest obstacle speed the rules allow, m/s. Default 20.58 (40 kt).
    pub max_obstacle_speed_mps: f64,
    /// The NoFly disc grows at `max_obstacle_speed_mps * nofly_speed_margin`. Default 1.25
    /// (25.7 m/s).
    pub nofly_speed_margin: f64,
    /// An observation implying more than `max_obstacle_speed_mps * flag_speed_factor` is
    /// flagged and not used. Default 2.0 (41.2 m/s).
    pub flag_speed_factor: f64,
    /// Position noise forgiven before computing an implied speed, metres. Default 2.0.
    pub position_noise_m: f64,
    /// Estimator parameters.
    pub estimator: EstimatorConfig,
    /// Stage-test thresholds.
    pub stages: StageConfig,
    /// Pin every obstacle to this stage (the simulator compares fixed stages). A track with
    /// fewer than 2 observations is NoFly regardless. Default `None` (automatic staging).
    pub forced_stage: Option<Stage>,
    /// Lap search of periodic tours ([`crate::periodic`]); `None` disables it. Not used
    /// with a forced stage. Default on.
    pub periodic: Option<PeriodicConfig>,
    /// Manoeuvre replay ([`crate::replay`]): once an obstacle off a periodic tour has
    /// enough history, its own past stretches predict it instead of its stage's model;
    /// `None` disables it. Not used with a forced stage. Default on.
    pub replay: Option<ReplayConfig>,
}

impl Default for PredictorConfig {
    fn default() -> Self {
        Self {
            max_obstacle_speed_mps: RULES_MAX_OBSTACLE_SPEED_MPS,
            nofly_speed_margin: 1.25,
            flag_speed_factor: 2.0,
            position_noise_m: 2.0,
            estimator: EstimatorConfig::default(),
            stages: StageConfig::default(),
            forced_stage: None,
            periodic: Some(PeriodicConfig::default()),
            replay: Some(ReplayConfig::default()),
        }
    }
}

impl PredictorConfig {
    /// Pins every obstacle to `stage`.
    pub fn forced_stage(mut self, stage: Option<Stage>) -> Self {
        self.forced_stage = stage;
        self
    }
    /// Sets the decision interval of the turn samples and models, seconds.
    pub fn decision_interval_s(mut self, dt_s: f64) -> Self {
        self.estimator.decision_interval_s = dt_s;
        self
    }
    fn nofly_speed_mps(&self) -> f64 {
        self.max_obstacle_speed_mps * self.nofly_speed_margin
    }
}

/// A public summary of one obstacle.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ObstacleSummary {
    /// Obstacle id.
    pub id: String,
    /// Stage in use (forced or automatic).
    pub stage: Stage,
    /// Current estimates.
    pub estimates: Estimates,
    /// Stored observations.
    pub observations: usize,
    /// Observations recognised as duplicates.
    pub duplicates: usize,
    /// Observations flagged as physically impossible.
    pub flagged: usize,
    /// Turn samples taken so far.
    pub turn_samples: usize,
    /// The newest observation.
    pub last_observation: Observation,
    /// Time of the oldest observation, seconds: with [`Self::last_observation`] it says
    /// how long the obstacle has been watched (a track keeps every observation it accepts).
    pub first_t_s: f64,
    /// Lowest and highest observed centre altitude, metres (as observed).
    pub alt_range_m: [f64; 2],
    /// The lap of a periodic tour it flies, when recognized ([`crate::periodic`]).
    pub lap: Option<Lap>,
    /// The most it has flown lately, m/s: the highest mean speed over any
    /// [`RECENT_SPEED_CHORD_S`] stretch of its track in the last [`RECENT_SPEED_WINDOW_S`]
    /// (stretches start a second apart), and at least its estimated speed. A sphere on the
    /// judges' out-and-back spline tours all but stops at each end of its tour, so its
    /// speed now reads slow just as it turns back to fly as fast as before; this does not.
    pub recent_max_speed_mps: f64,
    /// Every stage change with its statistic, oldest first.
    pub stage_history: Vec<StageChange>,
}

#[derive(Debug, Clone)]
struct Obstacle {
    track: Track,
    sampler: TurnSampler,
    stages: Characterizer,
    est: Estimates,
    turns: TurnSummary,
    hist: TurnHistogram,
    model: MotionModel,
    manoeuvres: Manoeuvres,
}

/// Tracks, characterizes and predicts every moving obstacle of a mission.
#[derive(Debug, Clone)]
pub struct Predictor {
    cfg: PredictorConfig,
    obstacles: BTreeMap<String, Obstacle>,
    dirty: BTreeSet<String>,
    map: Option<RiskMap>,
}

impl Predictor {
    /// An empty predictor.
    pub fn new(cfg: PredictorConfig) -> Self {
        Self {
            cfg,
            obstacles: BTreeMap::new(),
            dirty: BTreeSet::new(),
            map: None,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &PredictorConfig {
        &self.cfg
    }

    /// Feeds one observation of obstacle `id`. Out-of-order observations take their place
    /// by timestamp; the same observation twice is a `Duplicate` (nothing changes); one
    /// implying an impossible speed is `Flagged` and not used. Estimates and the stage are
    /// refreshed on acceptance, and the obstacle is marked for the next risk-map update.
    pub fn observe(&mut self, id: &str, obs: Observation) -> ObserveOutcome {
        if !(obs.t_s.is_finite()
            && obs.p_m[0].is_finite()
            && obs.p_m[1].is_finite()
            && obs.radius_m.is_finite())
        {
            return ObserveOutcome::Flagged {
                implied_speed_mps: f64::INFINITY,
            };
        }
        let flag = self.cfg.max_obstacle_speed_mps * self.cfg.flag_speed_factor;
        let cfg = &self.cfg;
        let ob = match self.obstacles.get_mut(id) {
            Some(ob) => ob,
            None => {
                let mut track = Track::default();
                track.insert(obs, flag, cfg.position_noise_m);
                let sampler = TurnSampler::default();
                let ob = new_obstacle(track, sampler, cfg);
                self.obstacles.insert(id.to_owned(), ob);
                self.dirty.insert(id.to_owned());
                return ObserveOutcome::Accepted;
            }
        };
        let (out, idx) = ob.track.insert(obs, flag, cfg.position_noise_m);
        if let Some(idx) = idx {
            if let Some(rc) = &cfg.replay {
                ob.manoeuvres.update(&ob.track, idx, rc);
            }
            let changed = ob.sampler.update(&ob.track, idx, &cfg.estimator);
            refresh(ob, cfg, changed > 0);
            self.dirty.insert(id.to_owned());
        }
        out
    }

    /// Summaries of every obstacle, ordered by id.
    pub fn obstacles(&self) -> impl Iterator<Item = ObstacleSummary> + '_ {
        self.obstacles.iter().map(|(id, ob)| summary(id, ob))
    }

    /// Summary of one obstacle.
    pub fn obstacle(&self, id: &str) -> Option<ObstacleSummary> {
        self.obstacles.get(id).map(|ob| summary(id, ob))
    }

    /// The newest observation time over every obstacle, seconds.
    pub fn latest_t_s(&self) -> Option<f64> {
        self.obstacles
            .values()
            .filter_map(|o| o.track.last())
            .map(|o| o.t_s)
            .reduce(f64::max)
    }

    /// The stage-`stage` motion model of obstacle `id` (from the same track and
    /// histograms; use it to compare stages on one obstacle).
    pub fn model_with_stage(&self, id: &str, stage: Stage) -> Option<MotionModel> {
        let ob = self.obstacles.get(id)?;
        Some(MotionModel::new(
            stage,
            &ob.est,
            &ob.hist,
            self.cfg.estimator.decision_interval_s,
            self.cfg.nofly_speed_mps(),
            &self.cfg.stages,
        ))
    }

    /// The motion model in use for obstacle `id`.
    pub fn model(&self, id: &str) -> Option<&MotionModel> {
        self.obstacles.get(id).map(|o| &o.model)
    }

    /// Samples `n` possible positions of obstacle `id`, `dt_s` seconds after its newest
    /// observation, with the model of its current stage. `None` for an unknown id.
    pub fn sample_future<R: Rng + ?Sized>(
        &self,
        id: &str,
        dt_s: f64,
        n: usize,
        rng: &mut R,
    ) -> Option<Vec<[f64; 2]>> {
        let ob = self.obstacles.get(id)?;
        if let Some(lap) = ob.model.lap
            && let Some(v) = sample_lap(&lap, &ob.track, dt_s, n, rng, self.periodic_gap_s())
        {
            return Some(v);
        }
        Some(
            ob.model
                .sample_future_with_replay(Some((&ob.track, &ob.manoeuvres)), dt_s, n, rng),
        )
    }

    fn periodic_gap_s(&self) -> f64 {
        self.cfg.periodic.map_or(5.0, |p| p.max_gap_s)
    }

    /// As [`Predictor::sample_future`], with the model of `stage` instead of the current one.
    pub fn sample_future_with_stage<R: Rng + ?Sized>(
        &self,
        id: &str,
        stage: Stage,
        dt_s: f64,
        n: usize,
        rng: &mut R,
    ) -> Option<Vec<[f64; 2]>> {
        Some(
            self.model_with_stage(id, stage)?
                .sample_future(dt_s, n, rng),
        )
    }

    /// The constant-velocity baseline: each obstacle a disc of its radius plus `buffer_m`
    /// around its position extrapolated at its estimated velocity.
    pub fn constant_velocity_field(&self, buffer_m: f64) -> ConstantVelocityField {
        ConstantVelocityField {
            discs: self
                .obstacles
                .values()
                .filter_map(|o| {
                    Some((
                        o.est.position_m,
                        o.est.velocity_mps,
                        o.est.t_s,
                        o.track.last()?.radius_m + buffer_m,
                    ))
                })
                .collect(),
        }
    }

    /// The risk map for `cfg`, `intended_path` and slice-0 time `t0_s`. When the cached
    /// map has the same parameters, only obstacles observed since the last call are redone
    /// (incremental); otherwise every obstacle is redone (a full rebuild, reusing the
    /// grid's allocation when `cfg` is unchanged). An invalid `cfg` yields an empty map
    /// over a default grid (validate with [`RiskMap::new`] first to see the error).
    pub fn risk_map(
        &mut self,
        cfg: &RiskMapConfig,
        intended_path: &[[f64; 2]],
        t0_s: f64,
    ) -> &RiskMap {
        let same_cfg = self.map.as_ref().is_some_and(|m| m.config() == cfg);
        let same_anchor = same_cfg
            && self
                .map
                .as_ref()
                .is_some_and(|m| m.intended_path() == intended_path && m.t0_s() == t0_s);
        if same_anchor {
            let dirty = std::mem::take(&mut self.dirty);
            let map = self.map.as_mut().expect("checked");
            for id in dirty {
                if let Some(o) = self.obstacles.get(&id) {
                    map.update_obstacle(&input(&id, o));
                }
            }
        } else {
            self.dirty.clear();
            let mut map = match self.map.take() {
                Some(mut m) if same_cfg => {
                    m.reset(intended_path, t0_s);
                    m
                }
                _ => RiskMap::new(cfg.clone(), intended_path, t0_s).unwrap_or_else(|_| {
                    RiskMap::new(RiskMapConfig::default(), &[], t0_s)
                        .expect("default config is valid")
                }),
            };
            map.rebuild(self.obstacles.iter().map(|(id, o)| input(id, o)));
            self.map = Some(map);
        }
        self.map.as_ref().expect("set above")
    }

    /// The cached risk map, if any.
    pub fn cached_risk_map(&self) -> Option<&RiskMap> {
        self.map.as_ref()
    }

    /// Builds a fresh map without touching the cache (a full rebuild).
    ///
    /// # Errors
    /// [`crate::RiskMapError`] for an invalid configuration.
    pub fn build_risk_map(
        &self,
        cfg: &RiskMapConfig,
        intended_path: &[[f64; 2]],
        t0_s: f64,
    ) -> Result<RiskMap, crate::RiskMapError> {
        let mut map = RiskMap::new(cfg.clone(), intended_path, t0_s)?;
        map.rebuild(self.obstacles.iter().map(|(id, o)| input(id, o)));
        Ok(map)
    }

    /// Redoes obstacle `id` in `map` (an explicit incremental update).
    pub fn update_map_obstacle(&self, map: &mut RiskMap, id: &str) {
        match self.obstacles.get(id) {
            Some(o) => map.update_obstacle(&input(id, o)),
            None => map.remove_obstacle(id),
        }
    }
}

/// `n` positions `dt_s` after the newest observation replayed from `lap`, spread as
/// [`Lap::sigma_m`] and [`Lap::jitter_s`] say; `None` where the track has a gap or a
/// mirror has run off its start (the caller then uses the obstacle's own model).
fn sample_lap<R: Rng + ?Sized>(
    lap: &Lap,
    track: &Track,
    dt_s: f64,
    n: usize,
    rng: &mut R,
    max_gap_s: f64,
) -> Option<Vec<[f64; 2]>> {
    let at = lap.at(track, dt_s, max_gap_s)?;
    Some(
        (0..n)
            .map(|_| at.particle(std::array::from_fn(|_| StandardNormal.sample(&mut *rng))))
            .collect(),
    )
}

fn input<'a>(id: &'a str, o: &'a Obstacle) -> ObstacleInput<'a> {
    ObstacleInput {
        id,
        model: &o.model,
        track: &o.track,
        radius_m: o.track.last().map_or(0.0, |l| l.radius_m),
        manoeuvres: Some(&o.manoeuvres),
    }
}

fn new_obstacle(track: Track, sampler: TurnSampler, cfg: &PredictorConfig) -> Obstacle {
    let turns = TurnSummary::from_window(&[], &cfg.estimator);
    let est = estimate::estimate(&track, &turns, &cfg.estimator).expect("track has an observation");
    let hist = TurnHistogram::build(&[], turns.w_max_radps, &cfg.stages);
    let model = MotionModel::new(
        Stage::NoFly,
        &est,
        &hist,
        cfg.estimator.decision_interval_s,
        cfg.nofly_speed_mps(),
        &cfg.stages,
    );
    let mut manoeuvres = Manoeuvres::default();
    if let Some(rc) = &cfg.replay {
        manoeuvres.update(&track, 0, rc);
    }
    let mut ob = Obstacle {
        track,
        sampler,
        stages: Characterizer::default(),
        est,
        turns,
        hist,
        model,
        manoeuvres,
    };
    refresh(&mut ob, cfg, true);
    ob
}

/// Refreshes the estimates (every observation) and, when the turn samples changed, the
/// turn summary, histograms and stage tests.
fn refresh(ob: &mut Obstacle, cfg: &PredictorConfig, samples_changed: bool) {
    if samples_changed {
        let window = ob.sampler.window(&cfg.estimator);
        ob.turns = TurnSummary::from_window(window, &cfg.estimator);
        ob.hist = TurnHistogram::build(window, ob.turns.w_max_radps, &cfg.stages);
    }
    let Some(est) = estimate::estimate(&ob.track, &ob.turns, &cfg.estimator) else {
        return;
    };
    let obs = ob.track.observations();
    let span = obs.last().map_or(0.0, |l| l.t_s) - obs.first().map_or(0.0, |f| f.t_s);
    if cfg.forced_stage.is_none() && (samples_changed || ob.stages.stage() == Stage::NoFly) {
        ob.stages.evaluate(
            est.t_s,
            obs.len(),
            span,
            ob.sampler.samples().len(),
            &ob.hist,
            &cfg.stages,
        );
    }
    let stage = effective_stage(ob, cfg);
    ob.est = est;
    ob.model = MotionModel::new(
        stage,
        &ob.est,
        &ob.hist,
        cfg.estimator.decision_interval_s,
        cfg.nofly_speed_mps(),
        &cfg.stages,
    );
    if cfg.forced_stage.is_none() && stage != Stage::NoFly {
        ob.model.lap = cfg.periodic.and_then(|pc| find_lap(&ob.track, &pc));
        // A mirror runs out where the track starts: replay predicts past it.
        if ob.model.lap.is_none_or(|l| l.kind == LapKind::Mirror)
            && ob.model.speed_mps > 0.0
            && let Some(rc) = cfg.replay
            && ob.manoeuvres.ready(&ob.track, &rc)
        {
            ob.model.replay = Some(ReplayModel {
                cfg: rc,
                max_speed_mps: ob.manoeuvres.max_speed_mps(&ob.track, &rc, 5.0),
            });
        }
        // A spline tour's leg (crate::leg): a share of the particles fly its cubic.
        if ob.model.lap.is_none()
            && let Some(rc) = cfg.replay
            && let Some((leg, _)) = crate::leg::fit(&ob.track, &rc, ob.model.speed_mps)
        {
            ob.model.leg = Some(leg);
        }
        // Too young for replay: the quadratic through its last seconds (crate::young).
        if ob.model.lap.is_none()
            && ob.model.replay.is_none()
            && let Some(rc) = cfg.replay
            && span < rc.min_history_s
        {
            ob.model.young = crate::young::fit(&ob.track, &rc, ob.model.speed_mps);
            if ob.model.young.is_some() && ob.model.stage == Stage::Random {
                ob.model.turn_bias_radps =
                    crate::young::turn_bias_radps(ob.sampler.window(&cfg.estimator), &rc);
            }
        }
    }
}

fn effective_stage(ob: &Obstacle, cfg: &PredictorConfig) -> Stage {
    if ob.track.len() < 2 {
        return Stage::NoFly;
    }
    cfg.forced_stage.unwrap_or(ob.stages.stage())
}

fn summary(id: &str, ob: &Obstacle) -> ObstacleSummary {
    ObstacleSummary {
        id: id.to_owned(),
        stage: ob.model.stage,
        estimates: ob.est,
        observations: ob.track.len(),
        duplicates: ob.track.duplicates(),
        flagged: ob.track.flagged(),
        turn_samples: ob.sampler.samples().len(),
        last_observation: *ob.track.last().expect("non-empty"),
        first_t_s: ob.track.observations()[0].t_s,
        alt_range_m: ob
            .track
            .observations()
            .iter()
            .fold([f64::INFINITY, f64::NEG_INFINITY], |r, o| {
                [r[0].min(o.alt_m), r[1].max(o.alt_m)]
            }),
        lap: ob.model.lap,
        recent_max_speed_mps: recent_max_speed_mps(&ob.track).max(ob.est.speed_mps),
        stage_history: ob.stages.history().to_vec(),
    }
}

/// The window [`ObstacleSummary::recent_max_speed_mps`] looks back over, seconds.
pub const RECENT_SPEED_WINDOW_S: f64 = 30.0;
/// The stretch [`ObstacleSummary::recent_max_speed_mps`] averages a speed over, seconds:
/// long enough that a metre of position noise moves it by a fraction of a m/s.
pub const RECENT_SPEED_CHORD_S: f64 = 3.0;

/// The highest mean speed over [`RECENT_SPEED_CHORD_S`] chords of `track` starting a
/// second apart in its last [`RECENT_SPEED_WINDOW_S`], m/s (0 for a shorter track).
fn recent_max_speed_mps(track: &Track) -> f64 {
    let (Some(first), Some(last)) = (track.observations().first(), track.last()) else {
        return 0.0;
    };
    let chord = RECENT_SPEED_CHORD_S;
    let end = last.t_s - chord;
    let mut t = (last.t_s - RECENT_SPEED_WINDOW_S).max(first.t_s);
    let mut best = 0.0_f64;
    let at = |t: f64| track.position_at(t.min(last.t_s), f64::INFINITY);
    while t <= end + 1e-9 {
        if let (Some(a), Some(b)) = (at(t), at(t + chord)) {
            best = best.max(geom::dist(a, b) / chord);
        }
        t += 1.0;
    }
    best
}

/// The constant-velocity baseline field: 1 inside any obstacle's disc (radius + buffer)
/// around its constant-velocity extrapolation, 0 elsewhere.
#[derive(Debug, Clone, Default)]
pub struct ConstantVelocityField {
    /// `(position at t, velocity, t, radius + buffer)` per obstacle.
    discs: Vec<([f64; 2], [f64; 2], f64, f64)>,
}

impl RiskField for ConstantVelocityField {
    fn risk(&self, p_m: [f64; 2], t_s: f64) -> f64 {
        for &(c, v, t, r) in &self.discs {
            let dt = t_s - t;
            let (dx, dy) = (p_m[0] - c[0] - v[0] * dt, p_m[1] - c[1] - v[1] * dt);
            if dx * dx + dy * dy <= r * r {
                return 1.0;
            }
        }
        0.0
    }
}
