//! The four characterization stages and the tests that move an obstacle between them
//! (seed 002, "Progression of obstacle characterization", "Random / Advanced probability
//! mapping", "Consideration of past behavior").
//!
//! - NoFly -> Random: at least `min_observations` observations spanning `min_track_span_s`
//!   (test `min_observations`, statistic = observation count).
//! - Random -> Advanced: Pearson's chi-square goodness of fit of the turn-rate histogram
//!   against uniform over `[-w_max, w_max]` rejects at `gof_promote_p` with at least
//!   `gof_min_samples` samples (test `chi_square_uniform`).
//! - Advanced -> Random (fall-back): the same test no longer rejects even at the lenient
//!   `gof_fallback_p`.
//! - Advanced -> Memory (an attempt, as the seed describes): Pearson's chi-square test of
//!   independence between the slice of the previous turn and the bin of the next turn
//!   rejects at `independence_p` with at least `independence_min_pairs` pairs (test
//!   `chi_square_independence`).
//! - Memory -> Advanced (regression): after `memory_dwell_samples` new samples, the
//!   weighted Jensen-Shannon divergence between the per-slice conditional distributions and
//!   the marginal one is below `js_regress_threshold_nats` (test `weighted_js_divergence`):
//!   the memory is statistically detectable but too weak to be worth its cost. A new memory
//!   attempt then waits `memory_retry_samples` samples.
//!
//! Every change is recorded as a [`StageChange`] with its statistic.

use crate::estimate::TurnSample;
use crate::stats;

/// Characterization stage of an obstacle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Stage {
    /// Nothing known: a disc growing at the assumed maximum speed.
    NoFly,
    /// Constant speed, turn rate uniform within the estimated capability.
    Random,
    /// Turn rate from the obstacle's own (smoothed) turn-rate histogram.
    Advanced,
    /// Turn rate from the histogram conditioned on the previous turn's slice.
    Memory,
}

impl Stage {
    /// The snake_case name used on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            Stage::NoFly => "no_fly",
            Stage::Random => "random",
            Stage::Advanced => "advanced",
            Stage::Memory => "memory",
        }
    }

    /// How unpredictable an obstacle in this stage is, in `[0, 1]`: the planner's sample
    /// budget hint (seed 002: more variable obstacles earn more samples). NoFly 1.0,
    /// Random 0.8, Advanced 0.5, Memory 0.3.
    pub fn variability(self) -> f64 {
        match self {
            Stage::NoFly => 1.0,
            Stage::Random => 0.8,
            Stage::Advanced => 0.5,
            Stage::Memory => 0.3,
        }
    }
}

/// One recorded stage change and the statistic behind it.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct StageChange {
    /// Mission time of the observation that triggered the change, seconds.
    pub t_s: f64,
    /// Stage before.
    pub from: Stage,
    /// Stage after.
    pub to: Stage,
    /// Name of the test: `min_observations`, `chi_square_uniform`,
    /// `chi_square_independence` or `weighted_js_divergence`.
    pub test: String,
    /// The test statistic (count, chi-square, or divergence in nats).
    pub statistic: f64,
    /// Degrees of freedom of a chi-square test.
    pub df: Option<usize>,
    /// p-value of a chi-square test.
    pub p_value: Option<f64>,
    /// The threshold the statistic or p-value was compared with.
    pub threshold: f64,
    /// Number of samples (observations, turn samples or pairs) the test used.
    pub samples: usize,
}

/// Stage-test thresholds, with documented defaults.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct StageConfig {
    /// Observations needed to leave NoFly. Default 5.
    pub min_observations: usize,
    /// Time the track must span to leave NoFly, seconds. Default 1.0.
    pub min_track_span_s: f64,
    /// Bins of the turn-rate histogram over `[-w_max, w_max]`. Default 9.
    pub turn_bins: usize,
    /// Slices of recent behaviour for Memory: the previous turn's bin grouped into this
    /// many equal groups (right, straight, left for 3). Must divide `turn_bins`. Default 3.
    pub memory_slices: usize,
    /// Additive smoothing of the histograms (per bin). Default 0.5.
    pub smoothing_alpha: f64,
    /// Turn samples needed for the uniformity test. Default 45 (5 per bin).
    pub gof_min_samples: usize,
    /// Random -> Advanced when the uniformity test's p-value is below this. Default 0.001.
    pub gof_promote_p: f64,
    /// Advanced -> Random when the uniformity test's p-value is at or above this.
    /// Default 0.05.
    pub gof_fallback_p: f64,
    /// Consecutive sample pairs needed for the independence test. Default 100.
    pub independence_min_pairs: usize,
    /// Advanced -> Memory (attempt) when the independence test's p-value is below this.
    /// Default 0.05.
    pub independence_p: f64,
    /// Memory -> Advanced when the weighted JS divergence is below this, nats.
    /// Default 0.02.
    pub js_regress_threshold_nats: f64,
    /// New samples a memory attempt runs before the divergence rule judges it. Default 20.
    pub memory_dwell_samples: usize,
    /// New samples after a regression before memory is attempted again. Default 60.
    pub memory_retry_samples: usize,
    /// Spread of the start position of the propagated particles (observation noise and
    /// fit error), metres, per axis. Default 2.
    pub start_position_sigma_m: f64,
    /// Spread of the start heading of the propagated particles, radians. Default 0.05.
    pub start_heading_sigma_rad: f64,
}

impl Default for StageConfig {
    fn default() -> Self {
        Self {
            min_observations: 5,
            min_track_span_s: 1.0,
            turn_bins: 9,
            memory_slices: 3,
            smoothing_alpha: 0.5,
            gof_min_samples: 45,
            gof_promote_p: 0.001,
            gof_fallback_p: 0.05,
            independence_min_pairs: 100,
            independence_p: 0.05,
            js_regress_threshold_nats: 0.02,
            memory_dwell_samples: 20,
            memory_retry_samples: 60,
            start_position_sigma_m: 2.0,
            start_heading_sigma_rad: 0.05,
        }
    }
}

/// Turn-rate histograms of one obstacle over `[-w_max, w_max]`.
#[derive(Debug, Clone, PartialEq)]
pub struct TurnHistogram {
    /// Half width of the histogram, rad/s (the turn-rate capability).
    pub w_max_radps: f64,
    /// Counts per bin (samples beyond the capability clamped to the edge bins).
    pub counts: Vec<usize>,
    /// Counts of samples within the capability only (used by the uniformity test).
    pub counts_within: Vec<usize>,
    /// `table[slice][bin]`: counts of a turn's bin given the previous turn's slice.
    pub table: Vec<Vec<usize>>,
    /// Bin of the most recent sample.
    pub last_bin: Option<usize>,
}

impl TurnHistogram {
    /// Builds the histograms from a window of turn samples.
    pub fn build(window: &[TurnSample], w_max_radps: f64, cfg: &StageConfig) -> Self {
        let k = cfg.turn_bins;
        let mut counts = vec![0; k];
        let mut counts_within = vec![0; k];
        let mut table = vec![vec![0; k]; cfg.memory_slices];
        let mut prev: Option<(i64, usize)> = None;
        let mut last_bin = None;
        for s in window {
            let b = bin_of(s.omega_radps, w_max_radps, k);
            counts[b] += 1;
            if s.omega_radps.abs() <= w_max_radps {
                counts_within[b] += 1;
            }
            if let Some((pk, pb)) = prev
                && pk + 1 == s.k
            {
                table[slice_of(pb, cfg)][b] += 1;
            }
            prev = Some((s.k, b));
            last_bin = Some(b);
        }
        Self {
            w_max_radps,
            counts,
            counts_within,
            table,
            last_bin,
        }
    }

    /// Number of consecutive pairs in the contingency table.
    pub fn pairs(&self) -> usize {
        self.table.iter().flatten().sum()
    }
}

/// Bin of a turn rate in a `k`-bin histogram over `[-w, w]`, clamped to the edge bins.
pub fn bin_of(omega_radps: f64, w_max_radps: f64, k: usize) -> usize {
    let f = (omega_radps + w_max_radps) / (2.0 * w_max_radps);
    ((f * k as f64).floor().max(0.0) as usize).min(k - 1)
}

/// Slice (group of bins) of a bin.
pub fn slice_of(bin: usize, cfg: &StageConfig) -> usize {
    (bin * cfg.memory_slices / cfg.turn_bins).min(cfg.memory_slices - 1)
}

/// The stage machine of one obstacle.
#[derive(Debug, Clone)]
pub struct Characterizer {
    stage: Stage,
    history: Vec<StageChange>,
    memory_entered_at: usize,
    memory_left_at: Option<usize>,
}

impl Default for Characterizer {
    fn default() -> Self {
        Self {
            stage: Stage::NoFly,
            history: Vec::new(),
            memory_entered_at: 0,
            memory_left_at: None,
        }
    }
}

impl Characterizer {
    /// The current stage.
    pub fn stage(&self) -> Stage {
        self.stage
    }

    /// Every change so far, oldest first.
    pub fn history(&self) -> &[StageChange] {
        &self.history
    }

    fn change(
        &mut self,
        t_s: f64,
        to: Stage,
        test: &str,
        statistic: f64,
        chi: Option<stats::ChiSquare>,
        threshold: f64,
        samples: usize,
    ) {
        self.history.push(StageChange {
            t_s,
            from: self.stage,
            to,
            test: test.to_owned(),
            statistic,
            df: chi.map(|c| c.df),
            p_value: chi.map(|c| c.p_value),
            threshold,
            samples,
        });
        self.stage = to;
    }

    /// Re-evaluates the stage after new data. `n_obs` and `span_s` describe the track,
    /// `total_samples` counts every turn sample ever taken (the dwell clock), `hist` is built
    /// from the current window. At most one change per call.
    pub fn evaluate(
        &mut self,
        t_s: f64,
        n_obs: usize,
        span_s: f64,
        total_samples: usize,
        hist: &TurnHistogram,
        cfg: &StageConfig,
    ) {
        match self.stage {
            Stage::NoFly => {
                if n_obs >= cfg.min_observations && span_s >= cfg.min_track_span_s {
                    self.change(
                        t_s,
                        Stage::Random,
                        "min_observations",
                        n_obs as f64,
                        None,
                        cfg.min_observations as f64,
                        n_obs,
                    );
                }
            }
            Stage::Random => {
                let n: usize = hist.counts_within.iter().sum();
                if n >= cfg.gof_min_samples
                    && let Some(c) = stats::chi_square_uniform(&hist.counts_within)
                    && c.p_value < cfg.gof_promote_p
                {
                    self.change(
                        t_s,
                        Stage::Advanced,
                        "chi_square_uniform",
                        c.statistic,
                        Some(c),
                        cfg.gof_promote_p,
                        n,
                    );
                }
            }
            Stage::Advanced => {
                let n: usize = hist.counts_within.iter().sum();
                if n >= cfg.gof_min_samples
                    && let Some(c) = stats::chi_square_uniform(&hist.counts_within)
                    && c.p_value >= cfg.gof_fallback_p
                {
                    self.change(
                        t_s,
                        Stage::Random,
                        "chi_square_uniform",
                        c.statistic,
                        Some(c),
                        cfg.gof_fallback_p,
                        n,
                    );
                    return;
                }
                let pairs = hist.pairs();
                let may_retry = self
                    .memory_left_at
                    .is_none_or(|at| total_samples >= at + cfg.memory_retry_samples);
                if pairs >= cfg.independence_min_pairs
                    && may_retry
                    && let Some(c) = stats::chi_square_independence(&hist.table)
                    && c.p_value < cfg.independence_p
                {
                    self.memory_entered_at = total_samples;
                    self.change(
                        t_s,
                        Stage::Memory,
                        "chi_square_independence",
                        c.statistic,
                        Some(c),
                        cfg.independence_p,
                        pairs,
                    );
                }
            }
            Stage::Memory => {
                if total_samples < self.memory_entered_at + cfg.memory_dwell_samples {
                    return;
                }
                let js = stats::weighted_js_divergence(&hist.table, cfg.smoothing_alpha);
                if js < cfg.js_regress_threshold_nats {
                    self.memory_left_at = Some(total_samples);
                    self.change(
                        t_s,
                        Stage::Advanced,
                        "weighted_js_divergence",
                        js,
                        None,
                        cfg.js_regress_threshold_nats,
                        hist.pairs(),
                    );
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_and_slices_split_the_capability_evenly() {
        // 9 bins over [-0.9, 0.9]: width 0.2; -0.9 -> 0, 0 -> 4, 0.85 -> 8, 5.0 -> clamped 8.
        assert_eq!(bin_of(-0.9, 0.9, 9), 0);
        assert_eq!(bin_of(0.0, 0.9, 9), 4);
        assert_eq!(bin_of(0.85, 0.9, 9), 8);
        assert_eq!(bin_of(5.0, 0.9, 9), 8);
        assert_eq!(bin_of(-5.0, 0.9, 9), 0);
        let cfg = StageConfig::default();
        assert_eq!(
            (0..9).map(|b| slice_of(b, &cfg)).collect::<Vec<_>>(),
            vec![0, 0, 0, 1, 1, 1, 2, 2, 2]
        );
    }
}
