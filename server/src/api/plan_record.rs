//! The stored form of a plan's answer (the `plans.body` column), separate from the API's
//! [`PlanOut`]: the API may rename or add fields without touching stored rows, and the
//! store never parses an API response back. Its stack items and start ([`StoredItem`],
//! [`StoredStart`]) are also those of the stored inputs ([`super::plan_inputs`]); both
//! convert to and from the pipeline's domain types, never to the API's directly.
//!
//! # Contract
//! - A record is a JSON object with `"record": 1` (the shape's version); what the row's
//!   columns already hold (ids, revision, seed, creation time) is not repeated.
//! - Rows written before records existed hold the serialized `PlanOut` (no `record` key);
//!   they are still read, as they are ([`stored_plan_out`]).
//! - The diff's `insert` is not stored: it is the stack from `first_changed` on.
//! - Units: degrees, metres MSL, metres, seconds (Unix), milliseconds for `compute_ms`.

use planner::ItemKind;
use serde::{Deserialize, Serialize};

use super::plan_compute::{GeoItem, Start};
use super::plans::{DiffOut, DynamicRisk, DynamicSource, PlanOut, PlanWaypoint, StartOut};
use crate::error::ApiError;
use crate::live::plan_view::{PlanObstacle, PlanWarning};
use crate::mission::Waypoint;
use crate::store::TelemetryRow;
use crate::store::plans::PlanRow;
use crate::time::format_rfc3339;

/// The version of the record shape written now.
pub const RECORD_VERSION: u32 = 1;

/// A stored plan answer, version 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanRecord {
    /// The shape's version ([`RECORD_VERSION`]).
    pub record: u32,
    /// The revision it revised (0 = the mission's waypoints).
    pub base_revision: i64,
    /// The planner's outcome name.
    pub outcome: String,
    /// Index to fly toward.
    pub current_index: usize,
    /// The whole stack.
    pub stack: Vec<StoredItem>,
    /// First stack index that differs from the base; none when nothing changed.
    pub first_changed: Option<usize>,
    /// Base items deleted from `first_changed` on.
    pub removed: usize,
    /// Peak risk of the plan and of the base stack.
    pub risk: f64,
    /// Peak risk of the base stack.
    pub base_risk: f64,
    /// Metres flown at risk 1.
    pub exposure_m: f64,
    /// Remaining route length, metres.
    pub length_m: f64,
    /// Avoid items in the remaining route.
    pub added: usize,
    /// Stack indices of too-sharp turns.
    pub turn_violations: Vec<usize>,
    /// Planning time, milliseconds.
    pub compute_ms: f64,
    /// Whether a risk map was used, and for how many moving obstacles.
    pub risk_map_used: bool,
    /// Moving obstacles observed in the window.
    pub moving_obstacles: usize,
    /// The start.
    pub start: StoredStart,
    /// Obstacles considered or left out (records written before live state: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub obstacles: Vec<PlanObstacle>,
    /// Warnings about the inputs.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<PlanWarning>,
    /// The live snapshot's observation batch number.
    #[serde(default)]
    pub observation_seq: i64,
    /// Batches applied but not in the map used (records before it: 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub map_lag_batches: i64,
    /// Age of the oldest of them, milliseconds.
    #[serde(default, skip_serializing_if = "is_zero_f64")]
    pub map_age_ms: f64,
    /// How long the next waypoint had been the target (records before it: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_pending_s: Option<f64>,
}

fn is_zero(v: &i64) -> bool {
    *v == 0
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's skip_serializing_if passes a reference
fn is_zero_f64(v: &f64) -> bool {
    *v == 0.0
}

/// One stored stack item.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StoredItem {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// `M` mission, `A` avoid, `S` search.
    pub kind: char,
    /// Index into the mission's waypoints (mission items).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mission_index: Option<usize>,
}

/// The stored start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StoredStart {
    /// Whether it came from aircraft telemetry (else from the stack).
    pub from_telemetry: bool,
    /// Unix seconds.
    pub t_s: f64,
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Heading, degrees true.
    pub heading_deg: f64,
    /// Ground speed, m/s.
    pub speed_mps: f64,
}

impl PlanRecord {
    /// The record of an answer.
    pub fn from_out(o: &PlanOut) -> Self {
        Self {
            record: RECORD_VERSION,
            base_revision: o.base_revision,
            outcome: o.outcome.clone(),
            current_index: o.current_index,
            stack: o
                .waypoints
                .iter()
                .map(|w| StoredItem::from(&GeoItem::from(w)))
                .collect(),
            first_changed: o.diff.first_changed,
            removed: o.diff.remove,
            risk: o.risk,
            base_risk: o.base_risk,
            exposure_m: o.exposure_m,
            length_m: o.length_m,
            added: o.added,
            turn_violations: o.turn_violations.clone(),
            compute_ms: o.compute_ms,
            risk_map_used: o.dynamic_risk.source == DynamicSource::RiskMap,
            moving_obstacles: o.dynamic_risk.obstacles,
            start: StoredStart::from(&Start::from(&o.start)),
            obstacles: o.obstacles.clone(),
            warnings: o.warnings.clone(),
            observation_seq: o.observation_seq,
            map_lag_batches: o.map_lag_batches,
            map_age_ms: o.map_age_ms,
            target_pending_s: o.target_pending_s,
        }
    }

    /// The answer, with what the row's columns hold.
    pub fn into_out(self, row: &PlanRow) -> Result<PlanOut, String> {
        let waypoints = self
            .stack
            .iter()
            .map(|s| GeoItem::try_from(s).map(|g| PlanWaypoint::from(&g)))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(PlanOut {
            plan_id: row.id.to_string(),
            mission_id: row.mission_id.to_string(),
            revision: row.revision,
            base_revision: self.base_revision,
            outcome: self.outcome,
            seed: row.seed,
            current_index: self.current_index,
            diff: DiffOut::of(self.first_changed, self.removed, &waypoints),
            waypoints,
            risk: self.risk,
            base_risk: self.base_risk,
            exposure_m: self.exposure_m,
            length_m: self.length_m,
            added: self.added,
            turn_violations: self.turn_violations,
            compute_ms: self.compute_ms,
            dynamic_risk: DynamicRisk {
                source: if self.risk_map_used {
                    DynamicSource::RiskMap
                } else {
                    DynamicSource::None
                },
                obstacles: self.moving_obstacles,
            },
            obstacles: self.obstacles,
            warnings: self.warnings,
            observation_seq: self.observation_seq,
            map_lag_batches: self.map_lag_batches,
            map_age_ms: self.map_age_ms,
            target_pending_s: self.target_pending_s,
            written_by: row.written_by.clone(),
            start: StartOut::from(&Start::from(&self.start)),
            created_at: format_rfc3339(row.created_at_s),
        })
    }

    /// The `plans.body` text.
    pub fn to_json(&self) -> Result<String, ApiError> {
        serde_json::to_string(self).map_err(|e| ApiError::Internal(format!("plan record: {e}")))
    }
}

impl From<&GeoItem> for StoredItem {
    fn from(g: &GeoItem) -> Self {
        Self {
            lat_deg: g.at.lat,
            lon_deg: g.at.lon,
            alt_msl_m: g.at.alt_msl_m,
            kind: match g.kind {
                ItemKind::Mission => 'M',
                ItemKind::Avoid => 'A',
                ItemKind::Search => 'S',
            },
            mission_index: g.mission_index,
        }
    }
}

impl TryFrom<&StoredItem> for GeoItem {
    type Error = String;
    fn try_from(s: &StoredItem) -> Result<Self, String> {
        Ok(Self {
            at: Waypoint {
                lat: s.lat_deg,
                lon: s.lon_deg,
                alt_msl_m: s.alt_msl_m,
            },
            kind: match s.kind {
                'M' => ItemKind::Mission,
                'A' => ItemKind::Avoid,
                'S' => ItemKind::Search,
                other => return Err(format!("unknown stack item kind '{other}'")),
            },
            mission_index: s.mission_index,
        })
    }
}

impl From<&Start> for StoredStart {
    fn from(s: &Start) -> Self {
        let a = &s.at;
        Self {
            from_telemetry: s.from_telemetry,
            t_s: a.t_s,
            lat_deg: a.lat_deg,
            lon_deg: a.lon_deg,
            alt_msl_m: a.alt_msl_m,
            heading_deg: a.heading_deg,
            speed_mps: a.speed_mps.unwrap_or(0.0),
        }
    }
}

impl From<&StoredStart> for Start {
    fn from(s: &StoredStart) -> Self {
        Self {
            from_telemetry: s.from_telemetry,
            at: TelemetryRow {
                t_s: s.t_s,
                lat_deg: s.lat_deg,
                lon_deg: s.lon_deg,
                alt_msl_m: s.alt_msl_m,
                heading_deg: s.heading_deg,
                speed_mps: Some(s.speed_mps),
            },
        }
    }
}

/// The API answer of a stored plan row: a record, or (rows written before records) the
/// serialized answer itself.
///
/// # Errors
/// 500 when the stored text is neither (the cause is logged, not returned).
pub fn stored_plan_out(row: &PlanRow) -> Result<PlanOut, ApiError> {
    let v: serde_json::Value = serde_json::from_str(&row.body)
        .map_err(|e| ApiError::Internal(format!("plan {}: stored body: {e}", row.id)))?;
    let out = if v.get("record").is_some() {
        serde_json::from_value::<PlanRecord>(v)
            .map_err(|e| e.to_string())
            .and_then(|r| r.into_out(row))
    } else {
        serde_json::from_value::<PlanOut>(v)
            .map(|o| PlanOut {
                written_by: row.written_by.clone(),
                ..o
            })
            .map_err(|e| e.to_string())
    };
    out.map_err(|e| ApiError::Internal(format!("plan {}: stored body: {e}", row.id)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::api::plans::{KindOut, StartSource};

    fn item(lat: f64, kind: KindOut, mission_index: Option<usize>) -> PlanWaypoint {
        PlanWaypoint {
            lat,
            lon: -76.43,
            alt_msl_m: 91.44,
            kind,
            mission_index,
        }
    }

    /// A stored row and the answer it must give back.
    fn sample() -> (PlanRow, PlanOut) {
        let waypoints = vec![
            item(38.14, KindOut::Mission, Some(0)),
            item(38.141, KindOut::Avoid, None),
            item(38.142, KindOut::Search, None),
            item(38.143, KindOut::Mission, Some(1)),
        ];
        let created_at_s = 1_781_449_200.25;
        let out = PlanOut {
            plan_id: "00000000000000ab".into(),
            mission_id: "m1".into(),
            revision: 2,
            base_revision: 1,
            outcome: "approximate".into(),
            seed: 7,
            current_index: 1,
            diff: DiffOut {
                first_changed: Some(1),
                remove: 1,
                insert: waypoints[1..].to_vec(),
            },
            waypoints,
            risk: 0.125,
            base_risk: 0.5,
            exposure_m: 3.5,
            length_m: 1234.5,
            added: 1,
            turn_violations: vec![1],
            compute_ms: 12.75,
            dynamic_risk: DynamicRisk {
                source: DynamicSource::RiskMap,
                obstacles: 2,
            },
            obstacles: vec![PlanObstacle {
                id: "0".into(),
                stage: crate::api::obstacles::StageOut::Random,
                last_t: created_at_s - 1.0,
                considered: true,
                left_out: None,
            }],
            warnings: vec![PlanWarning {
                code: "obstacles_left_out".into(),
                message: "1 left out".into(),
            }],
            observation_seq: 9,
            map_lag_batches: 1,
            map_age_ms: 2.5,
            target_pending_s: Some(12.5),
            written_by: "ops".into(),
            start: StartOut {
                source: StartSource::Telemetry,
                t: created_at_s - 0.5,
                lat: 38.139,
                lon: -76.431,
                alt_msl_m: 90.0,
                heading_deg: 45.0,
                speed_mps: 20.0,
            },
            created_at: format_rfc3339(created_at_s),
        };
        let row = PlanRow {
            id: out.plan_id.as_str().into(),
            mission_id: out.mission_id.as_str().into(),
            revision: out.revision,
            created_at_s,
            seed: out.seed,
            inputs: "{}".into(),
            body: String::new(),
            written_by: "ops".into(),
        };
        (row, out)
    }

    #[test]
    fn a_record_gives_back_the_answer_it_was_made_from() {
        let (mut row, out) = sample();
        row.body = PlanRecord::from_out(&out).to_json().unwrap();
        let v: serde_json::Value = serde_json::from_str(&row.body).unwrap();
        // Its own shape: versioned, nothing the row's columns hold, no API field names.
        assert_eq!(v["record"], 1);
        for api_only in [
            "plan_id",
            "mission_id",
            "seed",
            "created_at",
            "waypoints",
            "diff",
            "written_by",
        ] {
            assert!(v.get(api_only).is_none(), "{api_only} in {v}");
        }
        assert_eq!(stored_plan_out(&row).unwrap(), out);
        // Nothing changed: the diff inserts nothing.
        let (mut row, mut out) = sample();
        out.diff = DiffOut {
            first_changed: None,
            remove: 0,
            insert: vec![],
        };
        out.dynamic_risk.source = DynamicSource::None;
        out.start.source = StartSource::Stack;
        row.body = PlanRecord::from_out(&out).to_json().unwrap();
        assert_eq!(stored_plan_out(&row).unwrap(), out);
    }

    #[test]
    fn rows_written_before_records_still_read() {
        let (mut row, out) = sample();
        row.body = serde_json::to_string(&out).unwrap();
        assert_eq!(stored_plan_out(&row).unwrap(), out);
    }

    #[test]
    fn a_damaged_body_is_an_internal_error_not_a_panic() {
        let (mut row, out) = sample();
        let mut v = serde_json::to_value(PlanRecord::from_out(&out)).unwrap();
        v["stack"][0]["kind"] = serde_json::json!("X");
        row.body = v.to_string();
        assert!(matches!(stored_plan_out(&row), Err(ApiError::Internal(_))));
        row.body = "{\"record\": 1".into();
        assert!(matches!(stored_plan_out(&row), Err(ApiError::Internal(_))));
    }
}
