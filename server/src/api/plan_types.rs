//! The plan's wire types: the response document ([`PlanOut`] and its parts) and the
//! download formats, with their conversions from and to the pipeline's domain types
//! ([`super::plan_compute`]). The handlers are in [`super::plans`]; downloads in
//! [`super::plan_files`]; what is stored, in [`super::plan_inputs`] and
//! [`super::plan_record`].

use planner::{ItemKind, PlanOutcome};
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use super::plan_compute::{GeoItem, Start};
use crate::live::plan_view::{PlanObstacle, PlanWarning};
use crate::mission::Waypoint;
use crate::store::TelemetryRow;

/// What a stack item is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum KindOut {
    /// A mission waypoint (never moved).
    Mission,
    /// Inserted by the planner to avoid an obstacle.
    Avoid,
    /// A search-pattern waypoint.
    Search,
}

/// One stack item.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PlanWaypoint {
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// What it is for.
    pub kind: KindOut,
    /// Index into the mission's waypoints, for mission items.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mission_index: Option<usize>,
}

/// Tail rewrite from the base stack (MAVLink: delete `remove` items from `first_changed`,
/// then write `insert` from there).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct DiffOut {
    /// First index that differs; null when nothing changes.
    pub first_changed: Option<usize>,
    /// Items to delete from `first_changed` to the old end.
    pub remove: usize,
    /// Items to write from `first_changed` on.
    pub insert: Vec<PlanWaypoint>,
}

/// Where the plan starts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct StartOut {
    /// `telemetry` (the latest aircraft telemetry) or `stack` (no telemetry: the item before
    /// the current index, now).
    pub source: StartSource,
    /// Time, Unix seconds.
    pub t: f64,
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Heading, degrees true.
    pub heading_deg: f64,
    /// Ground speed, m/s: the newest telemetry's own, or when it reported none (the
    /// interop telemetry forms carry none), the median ground speed over the pairs of
    /// samples 0.5-2 s apart within its last 5 s; 0 = unknown (the route is then timed at the request's cruise speed).
    pub speed_mps: f64,
}

/// Where the start came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum StartSource {
    /// Latest aircraft telemetry.
    Telemetry,
    /// No telemetry: a stack item.
    Stack,
}

/// How dynamic risk was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct DynamicRisk {
    /// `risk_map` (predictor risk map from observations) or `none`.
    pub source: DynamicSource,
    /// Moving obstacles considered (in the risk map).
    pub obstacles: usize,
}

/// Dynamic risk source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum DynamicSource {
    /// The predictor's risk map.
    RiskMap,
    /// No moving obstacle observed: no dynamic risk.
    None,
}

/// A plan as returned and stored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PlanOut {
    /// Plan id.
    pub plan_id: String,
    /// Mission id.
    pub mission_id: String,
    /// Revision (1, 2, ... per mission).
    pub revision: i64,
    /// The revision this plan revises (0 = the mission's waypoints).
    pub base_revision: i64,
    /// `exact`, `approximate`, `timeout`, `no_safe_path`, `start_inside_obstacle`,
    /// `start_outside_fly_zone`, `waypoint_inside_cylinder`. A plan is returned in every
    /// case (the least-risk one found).
    pub outcome: String,
    /// Seed used (any unsigned 64-bit integer).
    #[schema(format = "uint64")]
    pub seed: u64,
    /// Index to fly toward now.
    pub current_index: usize,
    /// The whole revised stack (items before `current_index` unchanged).
    pub waypoints: Vec<PlanWaypoint>,
    /// Tail rewrite from the base stack.
    pub diff: DiffOut,
    /// Peak risk along the remaining route within the horizon (1 = enters a cylinder or
    /// leaves the fly zone).
    pub risk: f64,
    /// Peak risk of the base stack on the same metric.
    pub base_risk: f64,
    /// Risk exposure, metres flown at risk 1.
    pub exposure_m: f64,
    /// Remaining route length from the start, metres.
    pub length_m: f64,
    /// Avoid items in the remaining route.
    pub added: usize,
    /// Stack indices of avoid items whose turns are too sharp for the turn radius.
    pub turn_violations: Vec<usize>,
    /// Planning time, milliseconds (risk map included).
    pub compute_ms: f64,
    /// Dynamic risk used.
    pub dynamic_risk: DynamicRisk,
    /// Every observed moving obstacle: its stage, its newest observation time, and
    /// whether the plan considered it (else why not).
    #[serde(default)]
    pub obstacles: Vec<PlanObstacle>,
    /// Anything suspicious about the inputs (clock mismatch, obstacles left out, no
    /// telemetry); empty when all is well.
    #[serde(default)]
    pub warnings: Vec<PlanWarning>,
    /// Observation batches the plan saw: all batches up to this sequence number.
    #[serde(default)]
    pub observation_seq: i64,
    /// Batches this replica had applied but the plan's risk map did not hold yet (0: the
    /// map held every accepted batch). A plan uses the last published map instead of
    /// waiting for the rebuild of a batch just posted, while that batch is at most
    /// `max_map_age_ms` old; the map is always a whole snapshot (`observation_seq`).
    #[serde(default)]
    pub map_lag_batches: i64,
    /// How long the oldest batch missing from the map had been applied when the plan read
    /// it, milliseconds (0 when `map_lag_batches` is 0). A replay reports its own (0).
    #[serde(default)]
    pub map_age_ms: f64,
    /// How long the next waypoint of the stack had already been the target when the plan
    /// was made, seconds on the start's clock (carried from the base revision while that
    /// waypoint stays next). A route may reach a place at most `60 - target_pending_s`
    /// seconds later than straight progress along the mission and still be judged by the
    /// looser limit of its later arrival, so a waypoint is put off for at most 60 s in all.
    /// Absent when no waypoint is left (and in plans stored before it was kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_pending_s: Option<f64>,
    /// The name of the token that stored the plan, or `local` (no token).
    #[serde(default = "crate::auth::local")]
    pub written_by: String,
    /// The start.
    pub start: StartOut,
    /// When it was computed (RFC 3339).
    pub created_at: String,
}

/// `?format=` of a plan download.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct GetParams {
    /// `json` (default), `qgc-wpl` (QGC WPL 110 text) or `qgc-plan` (QGroundControl
    /// `.plan` JSON).
    pub format: Option<PlanFormat>,
}

/// A plan download format.
#[derive(Debug, Clone, Copy, Deserialize, ToSchema)]
pub enum PlanFormat {
    /// The plan as JSON.
    #[serde(rename = "json")]
    Json,
    /// QGC WPL 110 text, index 0 = home.
    #[serde(rename = "qgc-wpl")]
    QgcWpl,
    /// QGroundControl `.plan` JSON with the fly zone as geofence.
    #[serde(rename = "qgc-plan")]
    QgcPlan,
}

pub(crate) fn outcome_name(o: PlanOutcome) -> &'static str {
    match o {
        PlanOutcome::Exact => "exact",
        PlanOutcome::Approximate => "approximate",
        PlanOutcome::Timeout => "timeout",
        PlanOutcome::NoSafePath => "no_safe_path",
        PlanOutcome::StartInsideObstacle { .. } => "start_inside_obstacle",
        PlanOutcome::StartOutsideFlyZone => "start_outside_fly_zone",
        PlanOutcome::WaypointInsideCylinder { .. } => "waypoint_inside_cylinder",
        _ => "unknown",
    }
}

impl From<ItemKind> for KindOut {
    fn from(k: ItemKind) -> Self {
        match k {
            ItemKind::Mission => KindOut::Mission,
            ItemKind::Avoid => KindOut::Avoid,
            ItemKind::Search => KindOut::Search,
        }
    }
}

impl From<KindOut> for ItemKind {
    fn from(k: KindOut) -> Self {
        match k {
            KindOut::Mission => ItemKind::Mission,
            KindOut::Avoid => ItemKind::Avoid,
            KindOut::Search => ItemKind::Search,
        }
    }
}

impl From<&GeoItem> for PlanWaypoint {
    fn from(g: &GeoItem) -> Self {
        Self {
            lat: g.at.lat,
            lon: g.at.lon,
            alt_msl_m: g.at.alt_msl_m,
            kind: g.kind.into(),
            mission_index: g.mission_index,
        }
    }
}

impl From<&PlanWaypoint> for GeoItem {
    fn from(w: &PlanWaypoint) -> Self {
        Self {
            at: Waypoint {
                lat: w.lat,
                lon: w.lon,
                alt_msl_m: w.alt_msl_m,
            },
            kind: w.kind.into(),
            mission_index: w.mission_index,
        }
    }
}

impl From<&Start> for StartOut {
    fn from(s: &Start) -> Self {
        let a = &s.at;
        Self {
            source: if s.from_telemetry {
                StartSource::Telemetry
            } else {
                StartSource::Stack
            },
            t: a.t_s,
            lat: a.lat_deg,
            lon: a.lon_deg,
            alt_msl_m: a.alt_msl_m,
            heading_deg: a.heading_deg,
            // 0 = unknown on the wire.
            speed_mps: a.speed_mps.unwrap_or(0.0),
        }
    }
}

impl From<&StartOut> for Start {
    fn from(s: &StartOut) -> Self {
        Self {
            from_telemetry: s.source == StartSource::Telemetry,
            at: TelemetryRow {
                t_s: s.t,
                lat_deg: s.lat,
                lon_deg: s.lon,
                alt_msl_m: s.alt_msl_m,
                heading_deg: s.heading_deg,
                speed_mps: Some(s.speed_mps),
            },
        }
    }
}

impl DiffOut {
    /// The rewrite that deletes `remove` items from `first_changed` and writes the rest of
    /// `waypoints` (the whole new stack) from there.
    pub fn of(first_changed: Option<usize>, remove: usize, waypoints: &[PlanWaypoint]) -> Self {
        let first = first_changed
            .unwrap_or(waypoints.len())
            .min(waypoints.len());
        Self {
            first_changed,
            remove,
            insert: waypoints[first..].to_vec(),
        }
    }
}
