//! Obstacle characterization (seed 002): `GET /api/v1/missions/{id}/obstacles` lists
//! every obstacle with its stage, estimates and stage history (stationary cylinders too).
//!
//! It reads the mission's live snapshot ([`crate::live`]): the same predictor a plan asked
//! at the same moment uses (built from the stored observations on first use, so it
//! survives a restart, and kept current by every accepted batch).

use axum::extract::{Path, State};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;
use utoipa_axum::{router::OpenApiRouter, routes};

use predictor::{Stage, StageChange};

use crate::app::AppState;
use crate::error::ApiError;
use crate::mission::LatLon;
use wire::ids::MissionId;

/// Characterization stage of a moving obstacle.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StageOut {
    /// Nothing known yet: a disc growing at the rules' maximum speed with a margin.
    NoFly,
    /// Constant speed, turn rate uniform within the estimated capability.
    Random,
    /// Turn rate from the obstacle's own turn-rate histogram.
    Advanced,
    /// Turn rate conditioned on the previous turn.
    Memory,
}

impl From<Stage> for StageOut {
    fn from(s: Stage) -> Self {
        match s {
            Stage::NoFly => Self::NoFly,
            Stage::Random => Self::Random,
            Stage::Advanced => Self::Advanced,
            Stage::Memory => Self::Memory,
        }
    }
}

/// Moving sphere or stationary cylinder.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleKind {
    /// A moving sphere characterized from telemetry.
    Moving,
    /// A stationary cylinder from the mission (a hard constraint, not predicted).
    Stationary,
}

/// Kinematic estimates of a moving obstacle.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct EstimatesOut {
    /// Speed, m/s (0 when below 0.5 m/s).
    pub speed_mps: f64,
    /// Compass heading, degrees: 0 = north, 90 = east (clockwise); null when stationary.
    pub heading_deg: Option<f64>,
    /// Tightest demonstrated turn radius (5% quantile of the radii of circles through
    /// sampled triples, floored at 5 m), metres; null when no turn has been seen.
    pub min_turn_radius_m: Option<f64>,
    /// Turn-rate capability the models use, degrees per second.
    pub turn_rate_max_dps: f64,
    /// Most recent turn-rate sample (1 s decision interval), degrees per second,
    /// counter-clockwise (left) positive.
    pub turn_rate_dps: Option<f64>,
    /// Fitted current position.
    pub position: LatLon,
}

/// One stage change and the statistic behind it.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct StageChangeOut {
    /// Time of the observation that triggered it, Unix seconds.
    pub t: f64,
    /// Stage before.
    pub from: StageOut,
    /// Stage after.
    pub to: StageOut,
    /// `min_observations`, `chi_square_uniform`, `chi_square_independence` or
    /// `weighted_js_divergence`.
    pub test: String,
    /// The statistic: an observation count, a chi-square value or a divergence in nats.
    pub statistic: f64,
    /// Degrees of freedom of a chi-square test.
    pub df: Option<u64>,
    /// p-value of a chi-square test.
    pub p_value: Option<f64>,
    /// The threshold compared with (a p-value, a count or a divergence).
    pub threshold: f64,
    /// Samples the test used.
    pub samples: u64,
}

impl From<&StageChange> for StageChangeOut {
    fn from(c: &StageChange) -> Self {
        Self {
            t: c.t_s,
            from: c.from.into(),
            to: c.to.into(),
            test: c.test.clone(),
            statistic: c.statistic,
            df: c.df.map(|d| d as u64),
            p_value: c.p_value,
            threshold: c.threshold,
            samples: c.samples as u64,
        }
    }
}

/// The newest observation of a moving obstacle.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct LastObservationOut {
    /// Unix seconds.
    pub t: f64,
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude of the centre, metres MSL.
    pub alt_msl_m: f64,
    /// Sphere radius, metres.
    pub radius_m: f64,
}

/// A stationary cylinder.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct CylinderOut {
    /// Centre latitude, degrees.
    pub lat: f64,
    /// Centre longitude, degrees.
    pub lon: f64,
    /// Radius, metres.
    pub radius_m: f64,
    /// Top, metres MSL.
    pub top_msl_m: f64,
}

/// A recognized lap of an obstacle's periodic tour (README "Periodic tours").
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct LapOut {
    /// `repeat` (the tour comes round again) or `mirror` (a two-waypoint tour retracing
    /// itself after a turn-back).
    pub kind: String,
    /// The period, seconds (for a mirror, twice the time since the turn-back).
    pub period_s: f64,
    /// RMS distance between the track and its earlier lap, metres.
    pub rms_m: f64,
}

impl From<&predictor::Lap> for LapOut {
    fn from(l: &predictor::Lap) -> Self {
        Self {
            kind: match l.kind {
                predictor::LapKind::Repeat => "repeat",
                predictor::LapKind::Mirror => "mirror",
            }
            .into(),
            period_s: l.period_s,
            rms_m: l.rms_m,
        }
    }
}

/// One obstacle of the mission.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct ObstacleOut {
    /// Obstacle id.
    pub id: String,
    /// Moving or stationary.
    pub kind: ObstacleKind,
    /// Characterization stage (moving obstacles).
    pub stage: Option<StageOut>,
    /// Current estimates (moving obstacles).
    pub estimates: Option<EstimatesOut>,
    /// Observations used (moving obstacles; 0 for cylinders).
    pub observation_count: u64,
    /// Observations refused as physically impossible (implied speed above 41 m/s).
    pub flagged_count: u64,
    /// The newest observation (moving obstacles).
    pub last_observation: Option<LastObservationOut>,
    /// Every stage change with its statistic, oldest first (moving obstacles).
    pub stage_history: Vec<StageChangeOut>,
    /// How long it has been watched: its newest observation less its oldest, seconds
    /// (moving obstacles). A moving obstacle watched for less than 120 s with no `lap` is
    /// still being learned: plans warn `tours_not_learned`.
    pub watched_s: Option<f64>,
    /// The lap of the periodic tour it flies, once recognized (moving obstacles; null
    /// until then, and for obstacles that do not retrace their path).
    pub lap: Option<LapOut>,
    /// The cylinder (stationary obstacles).
    pub cylinder: Option<CylinderOut>,
}

/// Every obstacle of a mission: moving ones with their characterization, then the
/// mission's stationary cylinders.
#[utoipa::path(get, path = "/api/v1/missions/{id}/obstacles", tag = "prediction",
    params(("id" = String, Path, description = "Mission id")),
    responses(
        (status = 200, description = "Moving obstacles (by id) with stage, estimates, observation count and stage history, then stationary cylinders", body = [ObstacleOut]),
    ))]
async fn list_obstacles(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
) -> Result<axum::Json<Vec<ObstacleOut>>, ApiError> {
    let mission = state
        .store
        .get_mission(&id)
        .await?
        .ok_or_else(|| ApiError::not_found("mission", &id))?;
    let snap = state.live.predictor_view(&state, &mission).await?;
    let mut out: Vec<ObstacleOut> = {
        snap.predictor
            .obstacles()
            .map(|s| {
                let (lat, lon) = snap.frame.to_geodetic(s.estimates.position_m);
                let (olat, olon) = snap.frame.to_geodetic(s.last_observation.p_m);
                ObstacleOut {
                    id: s.id.clone(),
                    kind: ObstacleKind::Moving,
                    stage: Some(s.stage.into()),
                    estimates: Some(EstimatesOut {
                        speed_mps: s.estimates.speed_mps,
                        heading_deg: s.estimates.heading_deg,
                        min_turn_radius_m: s.estimates.min_turn_radius_m,
                        turn_rate_max_dps: s.estimates.turn_rate_max_dps,
                        turn_rate_dps: s.estimates.turn_rate_dps,
                        position: LatLon { lat, lon },
                    }),
                    observation_count: s.observations as u64,
                    flagged_count: s.flagged as u64,
                    last_observation: Some(LastObservationOut {
                        t: s.last_observation.t_s,
                        lat: olat,
                        lon: olon,
                        alt_msl_m: s.last_observation.alt_m,
                        radius_m: s.last_observation.radius_m,
                    }),
                    stage_history: s.stage_history.iter().map(StageChangeOut::from).collect(),
                    watched_s: Some(s.last_observation.t_s - s.first_t_s),
                    lap: s.lap.as_ref().map(LapOut::from),
                    cylinder: None,
                }
            })
            .collect()
    };
    for (i, c) in mission.content.stationary_obstacles.iter().enumerate() {
        out.push(ObstacleOut {
            id: if c.id.is_empty() {
                format!("stationary-{i}")
            } else {
                c.id.to_string()
            },
            kind: ObstacleKind::Stationary,
            stage: None,
            estimates: None,
            observation_count: 0,
            flagged_count: 0,
            last_observation: None,
            stage_history: Vec::new(),
            watched_s: None,
            lap: None,
            cylinder: Some(CylinderOut {
                lat: c.lat,
                lon: c.lon,
                radius_m: c.radius_m,
                top_msl_m: c.top_msl_m,
            }),
        });
    }
    Ok(axum::Json(out))
}

/// Obstacle routes.
pub(crate) fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new().routes(routes!(list_obstacles))
}
