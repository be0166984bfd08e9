//! The stored form of a plan's inputs (the `plans.inputs` column): what replay needs to
//! recompute the plan, separate from the API's shapes and from the pipeline's
//! [`PlanInputs`], converted at the edge ([`InputsRecord::of`], [`stored_inputs`]).
//!
//! # Contract
//! - A record is a JSON object with `"inputs": 1` (the shape's version). The seed is the
//!   row's `seed` column and is not repeated.
//! - Stack items and the start have the plan record's shapes ([`StoredItem`],
//!   [`StoredStart`]).
//! - The observations are named, not copied: `{"through": seq}` (every stored batch up to
//!   that sequence number), `{"window": {...}}` (plans stored before live state) or, for
//!   the first stored plans only, `{"given": [[obstacle_id, t_s, lat_deg, lon_deg,
//!   alt_msl_m, radius_m], ...]}`.
//! - Rows written before records hold the pipeline's inputs as they were serialized then,
//!   the stack and start in the API's `PlanWaypoint` and `StartOut` shapes (no `inputs`
//!   key); they are upgraded to version 1 as a JSON document ([`upgrade_unversioned`]) and
//!   read like any record, so that the API may change without breaking them.
//! - Units: degrees, metres MSL, metres, seconds (Unix), m/s, milliseconds for
//!   `deadline_ms`, Unix microseconds in the window.

use planner::Strategy;
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use super::plan_compute::{GeoItem, Observations, PlanInputs, Start};
use super::plan_record::{StoredItem, StoredStart};
use crate::error::ApiError;
use crate::store::ObservationRow;
use crate::store::plans::PlanRow;
use wire::ids::MissionId;

/// The version of the inputs shape written now.
pub const INPUTS_VERSION: u32 = 1;

/// Stored plan inputs, version 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputsRecord {
    /// The shape's version ([`INPUTS_VERSION`]).
    pub inputs: u32,
    /// `bisection`, `insertion` or `none`.
    pub strategy: StoredStrategy,
    /// Compute budget, milliseconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deadline_ms: Option<u64>,
    /// Prediction horizon, seconds.
    pub horizon_s: f64,
    /// Cruise speed, m/s.
    pub speed_mps: f64,
    /// Turn radius, metres.
    pub turn_radius_m: f64,
    /// True when `turn_radius_m` is the default (the request gave none).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub turn_radius_assumed: bool,
    /// The largest bank shown in the aircraft's telemetry by this plan, degrees (absent:
    /// none seen, as in plans stored before it was kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shown_bank_deg: Option<f64>,
    /// The autopilot's acceptance radius, metres (absent: the default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acceptance_radius_m: Option<f64>,
    /// The autopilot's L1 period, seconds (absent: the default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub l1_period_s: Option<f64>,
    /// Index in `stack` the aircraft flies toward.
    pub current_index: usize,
    /// The base stack (empty = the mission's waypoints).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stack: Vec<StoredItem>,
    /// The start.
    pub start: StoredStart,
    /// Which observations the snapshot was built from.
    pub observations: StoredObservations,
    /// Since when the next fixed item has been the target (absent in plans stored before
    /// it was kept: replayed as unknown, as they were planned).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_since_s: Option<f64>,
    /// The missed waypoint the plan flew again (absent: none, as in plans stored before
    /// revisits).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub revisit: Option<StoredMissed>,
    /// The waypoint ahead captured on the way, skipped by the plan (absent: none, as in
    /// plans stored before the skip).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub captured: Option<StoredMissed>,
    /// The waypoint just passed that the flight ahead may yet capture, judged again at the
    /// next plan (absent: none, as in plans stored before the watch).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub watch: Option<StoredWatch>,
    /// The limit the plan was asked with: a next waypoint pursued longer than this many
    /// seconds is put off to the end of the stack (`defer_after_s`; 0: never; absent:
    /// never, as plans stored before the rule were planned).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub defer_after_s: Option<f64>,
}

/// The stored form of [`planner::Watch`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StoredWatch {
    /// Its index in the base stack.
    pub stack_index: usize,
    /// Since when it was the target, seconds on the start's clock.
    pub since_s: f64,
    /// Until when the flight ahead counts, seconds on the start's clock.
    pub until_s: f64,
}

/// The stored form of [`planner::Missed`] (and of [`planner::Captured`], the same three
/// numbers).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StoredMissed {
    /// Its index in the base stack.
    pub stack_index: usize,
    /// Its index in the mission's waypoints.
    pub mission_index: usize,
    /// The telemetry's closest approach to it, metres.
    pub closest_m: f64,
}

/// A stored strategy name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StoredStrategy {
    /// [`Strategy::Bisection`].
    Bisection,
    /// [`Strategy::Insertion`].
    Insertion,
    /// [`Strategy::None`].
    None,
}

/// The stored form of [`Observations`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StoredObservations {
    /// Every stored batch up to this sequence number.
    Through(i64),
    /// The stored observations of a window.
    Window(ObservationWindow),
    /// Listed: `[obstacle_id, t_s, lat_deg, lon_deg, alt_msl_m, radius_m]` each.
    Given(Vec<(String, f64, f64, f64, f64, f64)>),
}

/// The stored observations a plan used: `after_us < t <= until_us`, received by
/// `received_until_us` (Unix microseconds).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ObservationWindow {
    /// Exclusive lower bound of observation time.
    pub after_us: i64,
    /// Inclusive upper bound of observation time.
    pub until_us: i64,
    /// Only observations received by then (the plan request's time).
    pub received_until_us: i64,
}

impl ObservationWindow {
    /// Fetches exactly these observations.
    ///
    /// # Errors
    /// A database failure.
    pub async fn fetch(
        &self,
        store: &crate::store::Store,
        mission_id: &MissionId,
    ) -> Result<Vec<ObservationRow>, ApiError> {
        Ok(store
            .list_observations_window(
                mission_id,
                self.after_us,
                self.until_us,
                self.received_until_us,
            )
            .await?)
    }
}

impl InputsRecord {
    /// The record of `inputs` (its seed goes to the row's column).
    pub fn of(inputs: &PlanInputs) -> Self {
        Self {
            inputs: INPUTS_VERSION,
            strategy: match inputs.strategy {
                Strategy::Bisection => StoredStrategy::Bisection,
                Strategy::Insertion => StoredStrategy::Insertion,
                Strategy::None => StoredStrategy::None,
            },
            deadline_ms: inputs.deadline_ms,
            horizon_s: inputs.horizon_s,
            speed_mps: inputs.aircraft.speed_mps,
            turn_radius_m: inputs.aircraft.turn_radius_m,
            turn_radius_assumed: inputs.turn_radius_assumed,
            shown_bank_deg: inputs.shown_bank_deg,
            acceptance_radius_m: inputs.acceptance_radius_m,
            l1_period_s: inputs.l1_period_s,
            current_index: inputs.current_index,
            stack: inputs.stack.iter().map(StoredItem::from).collect(),
            start: StoredStart::from(&inputs.start),
            observations: match &inputs.observations {
                Observations::Through(seq) => StoredObservations::Through(*seq),
                Observations::Window(w) => StoredObservations::Window(*w),
                Observations::Given(rows) => StoredObservations::Given(
                    rows.iter()
                        .map(|o| {
                            (
                                o.obstacle_id.clone(),
                                o.t_s,
                                o.lat_deg,
                                o.lon_deg,
                                o.alt_msl_m,
                                o.radius_m,
                            )
                        })
                        .collect(),
                ),
            },
            target_since_s: inputs.target_since_s,
            revisit: inputs.revisit.map(|m| StoredMissed {
                stack_index: m.stack_index,
                mission_index: m.mission_index,
                closest_m: m.closest_m,
            }),
            captured: inputs.captured.map(|c| StoredMissed {
                stack_index: c.stack_index,
                mission_index: c.mission_index,
                closest_m: c.closest_m,
            }),
            watch: inputs.watch.map(|w| StoredWatch {
                stack_index: w.stack_index,
                since_s: w.since_s,
                until_s: w.until_s,
            }),
            defer_after_s: Some(inputs.defer_after_s),
        }
    }

    /// The pipeline's inputs, with the row's `seed`.
    ///
    /// # Errors
    /// An unknown stack item kind.
    pub fn into_inputs(self, seed: u64) -> Result<PlanInputs, String> {
        Ok(PlanInputs {
            seed,
            strategy: match self.strategy {
                StoredStrategy::Bisection => Strategy::Bisection,
                StoredStrategy::Insertion => Strategy::Insertion,
                StoredStrategy::None => Strategy::None,
            },
            deadline_ms: self.deadline_ms,
            horizon_s: self.horizon_s,
            aircraft: planner::Aircraft {
                speed_mps: self.speed_mps,
                turn_radius_m: self.turn_radius_m,
            },
            turn_radius_assumed: self.turn_radius_assumed,
            shown_bank_deg: self.shown_bank_deg,
            acceptance_radius_m: self.acceptance_radius_m,
            l1_period_s: self.l1_period_s,
            current_index: self.current_index,
            stack: self
                .stack
                .iter()
                .map(GeoItem::try_from)
                .collect::<Result<_, _>>()?,
            start: Start::from(&self.start),
            observations: match self.observations {
                StoredObservations::Through(seq) => Observations::Through(seq),
                StoredObservations::Window(w) => Observations::Window(w),
                StoredObservations::Given(list) => Observations::Given(
                    list.into_iter()
                        .map(
                            |(obstacle_id, t_s, lat_deg, lon_deg, alt_msl_m, radius_m)| {
                                ObservationRow {
                                    obstacle_id,
                                    t_s,
                                    lat_deg,
                                    lon_deg,
                                    alt_msl_m,
                                    radius_m,
                                }
                            },
                        )
                        .collect(),
                ),
            },
            target_since_s: self.target_since_s,
            revisit: self.revisit.map(|m| planner::Missed {
                stack_index: m.stack_index,
                mission_index: m.mission_index,
                closest_m: m.closest_m,
            }),
            captured: self.captured.map(|c| planner::Captured {
                stack_index: c.stack_index,
                mission_index: c.mission_index,
                closest_m: c.closest_m,
            }),
            watch: self.watch.map(|w| planner::Watch {
                stack_index: w.stack_index,
                since_s: w.since_s,
                until_s: w.until_s,
            }),
            defer_after_s: self.defer_after_s.unwrap_or(0.0),
        })
    }

    /// The `plans.inputs` text.
    ///
    /// # Errors
    /// 500 when it cannot be serialized (a non-finite number).
    pub fn to_json(&self) -> Result<String, ApiError> {
        serde_json::to_string(self).map_err(|e| ApiError::Internal(format!("plan inputs: {e}")))
    }
}

/// The inputs of a stored plan row: a record, or (rows written before records) the old
/// serialized inputs, upgraded.
///
/// # Errors
/// 500 when the stored text is neither (the cause is logged, not returned).
pub fn stored_inputs(row: &PlanRow) -> Result<PlanInputs, ApiError> {
    let read = || -> Result<PlanInputs, String> {
        let mut v: Value = serde_json::from_str(&row.inputs).map_err(|e| e.to_string())?;
        if v.get("inputs").is_none() {
            upgrade_unversioned(&mut v)?;
        }
        serde_json::from_value::<InputsRecord>(v)
            .map_err(|e| e.to_string())?
            .into_inputs(row.seed)
    };
    read().map_err(|e| ApiError::Internal(format!("plan {}: stored inputs: {e}", row.id)))
}

/// Rewrites inputs stored before records (the stack and start in the API's shapes, the
/// observations in three optional fields) as a version 1 record.
///
/// # Errors
/// When `v` is not such a document (the field that is not).
pub fn upgrade_unversioned(v: &mut Value) -> Result<(), String> {
    fn rename(o: &mut Value, pairs: &[(&str, &str)]) -> Result<(), String> {
        let o = o.as_object_mut().ok_or("not an object")?;
        for (from, to) in pairs {
            let x = o.remove(*from).ok_or(format!("no `{from}`"))?;
            o.insert((*to).to_string(), x);
        }
        Ok(())
    }
    let o = v.as_object_mut().ok_or("inputs: not an object")?;
    o.remove("seed");
    o.insert("inputs".into(), json!(INPUTS_VERSION));
    for item in o
        .get_mut("stack")
        .and_then(Value::as_array_mut)
        .into_iter()
        .flatten()
    {
        let kind = match item["kind"].as_str() {
            Some("mission") => "M",
            Some("avoid") => "A",
            Some("search") => "S",
            other => return Err(format!("stack: unknown kind {other:?}")),
        };
        item["kind"] = json!(kind);
        rename(item, &[("lat", "lat_deg"), ("lon", "lon_deg")])?;
    }
    let start = o.get_mut("start").ok_or("no `start`")?;
    let from_telemetry = match start["source"].as_str() {
        Some("telemetry") => true,
        Some("stack") => false,
        other => return Err(format!("start: unknown source {other:?}")),
    };
    rename(
        start,
        &[
            ("source", "from_telemetry"),
            ("t", "t_s"),
            ("lat", "lat_deg"),
            ("lon", "lon_deg"),
        ],
    )?;
    start["from_telemetry"] = json!(from_telemetry);
    let mut take = |k: &str| o.remove(k).filter(|x| !x.is_null());
    let observations = if let Some(seq) = take("observation_seq") {
        json!({ "through": seq })
    } else if let Some(w) = take("observation_window") {
        json!({ "window": w })
    } else {
        let list = take("observations").unwrap_or_else(|| json!([]));
        let given: Vec<Value> = list
            .as_array()
            .ok_or("observations: not a list")?
            .iter()
            .map(|x| {
                json!([
                    x["obstacle_id"],
                    x["t"],
                    x["lat"],
                    x["lon"],
                    x["alt_msl_m"],
                    x["radius_m"]
                ])
            })
            .collect();
        json!({ "given": given })
    };
    o.insert("observations".into(), observations);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::Waypoint;
    use crate::store::TelemetryRow;
    use planner::ItemKind;

    fn row(inputs: &str) -> PlanRow {
        PlanRow {
            id: "00000000000000ab".into(),
            mission_id: "m1".into(),
            revision: 2,
            created_at_s: 1_781_449_200.25,
            seed: 7,
            inputs: inputs.into(),
            body: String::new(),
            written_by: "local".into(),
        }
    }

    /// The inputs the old rows below were written from.
    fn expected(observations: Observations) -> PlanInputs {
        PlanInputs {
            seed: 7,
            strategy: Strategy::Insertion,
            deadline_ms: None,
            horizon_s: 60.0,
            aircraft: planner::Aircraft {
                speed_mps: 20.0,
                turn_radius_m: 40.0,
            },
            turn_radius_assumed: false,
            shown_bank_deg: None,
            acceptance_radius_m: None,
            l1_period_s: None,
            current_index: 1,
            stack: vec![
                GeoItem {
                    at: Waypoint {
                        lat: 38.14,
                        lon: -76.43,
                        alt_msl_m: 91.44,
                    },
                    kind: ItemKind::Mission,
                    mission_index: Some(0),
                },
                GeoItem {
                    at: Waypoint {
                        lat: 38.141,
                        lon: -76.431,
                        alt_msl_m: 100.5,
                    },
                    kind: ItemKind::Avoid,
                    mission_index: None,
                },
            ],
            start: Start {
                from_telemetry: true,
                at: TelemetryRow {
                    t_s: 1_781_449_199.75,
                    lat_deg: 38.139,
                    lon_deg: -76.4301,
                    alt_msl_m: 90.0,
                    heading_deg: 45.5,
                    speed_mps: Some(19.5),
                },
            },
            observations,
            target_since_s: None,
            revisit: None,
            captured: None,
            watch: None,
            // Absent from rows stored before the rule: never put off.
            defer_after_s: 0.0,
        }
    }

    /// Inputs as the pipeline serialized them before records, ending in `tail`.
    fn old_row(tail: &str) -> PlanRow {
        row(&format!(
            r#"{{"seed":7,"strategy":"insertion","deadline_ms":null,"horizon_s":60.0,"speed_mps":20.0,"turn_radius_m":40.0,"current_index":1,"stack":[{{"lat":38.14,"lon":-76.43,"alt_msl_m":91.44,"kind":"mission","mission_index":0}},{{"lat":38.141,"lon":-76.431,"alt_msl_m":100.5,"kind":"avoid"}}],"start":{{"source":"telemetry","t":1781449199.75,"lat":38.139,"lon":-76.4301,"alt_msl_m":90.0,"heading_deg":45.5,"speed_mps":19.5}}{tail}}}"#
        ))
    }

    #[test]
    fn inputs_stored_before_records_still_read() {
        let through = old_row(r#","observation_seq":9"#);
        assert_eq!(
            stored_inputs(&through).unwrap(),
            expected(Observations::Through(9))
        );
        let window =
            old_row(r#","observation_window":{"after_us":1,"until_us":2,"received_until_us":3}"#);
        assert_eq!(
            stored_inputs(&window).unwrap(),
            expected(Observations::Window(ObservationWindow {
                after_us: 1,
                until_us: 2,
                received_until_us: 3,
            }))
        );
        let given = old_row(
            r#","observations":[{"obstacle_id":"b","t":1781449199.5,"lat":38.15,"lon":-76.42,"alt_msl_m":120.0,"radius_m":15.25}]"#,
        );
        let obs = ObservationRow {
            obstacle_id: "b".into(),
            t_s: 1_781_449_199.5,
            lat_deg: 38.15,
            lon_deg: -76.42,
            alt_msl_m: 120.0,
            radius_m: 15.25,
        };
        assert_eq!(
            stored_inputs(&given).unwrap(),
            expected(Observations::Given(vec![obs]))
        );
        assert_eq!(
            stored_inputs(&old_row("")).unwrap(),
            expected(Observations::Given(vec![]))
        );
    }

    #[test]
    fn a_record_gives_back_the_inputs_it_was_made_from() {
        for observations in [
            Observations::Through(9),
            Observations::Given(vec![ObservationRow {
                obstacle_id: "b".into(),
                t_s: 1.5,
                lat_deg: 38.15,
                lon_deg: -76.42,
                alt_msl_m: 120.0,
                radius_m: 15.25,
            }]),
        ] {
            let inputs = expected(observations);
            let text = InputsRecord::of(&inputs).to_json().unwrap();
            let v: Value = serde_json::from_str(&text).unwrap();
            assert_eq!(v["inputs"], 1);
            // Its own shape: no seed (the row has it), no API field names.
            assert!(v.get("seed").is_none(), "{v}");
            assert!(v["start"].get("source").is_none(), "{v}");
            assert!(v["stack"][0].get("lat").is_none(), "{v}");
            assert_eq!(stored_inputs(&row(&text)).unwrap(), inputs);
        }
        // The aircraft's optional facts come back as given, and absent when not given.
        let inputs = PlanInputs {
            turn_radius_assumed: true,
            shown_bank_deg: Some(41.5),
            acceptance_radius_m: Some(30.0),
            l1_period_s: Some(12.0),
            revisit: Some(planner::Missed {
                stack_index: 0,
                mission_index: 0,
                closest_m: 41.25,
            }),
            captured: Some(planner::Captured {
                stack_index: 2,
                mission_index: 1,
                closest_m: 12.5,
            }),
            watch: Some(planner::Watch {
                stack_index: 1,
                since_s: 1_781_449_150.5,
                until_s: 1_781_449_205.75,
            }),
            defer_after_s: 300.0,
            ..expected(Observations::Through(9))
        };
        let text = InputsRecord::of(&inputs).to_json().unwrap();
        let v: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(
            (
                &v["turn_radius_assumed"],
                &v["shown_bank_deg"],
                &v["acceptance_radius_m"],
                &v["l1_period_s"]
            ),
            (&json!(true), &json!(41.5), &json!(30.0), &json!(12.0))
        );
        assert_eq!(
            v["revisit"],
            json!({"stack_index": 0, "mission_index": 0, "closest_m": 41.25})
        );
        assert_eq!(
            v["captured"],
            json!({"stack_index": 2, "mission_index": 1, "closest_m": 12.5})
        );
        assert_eq!(
            v["watch"],
            json!({"stack_index": 1, "since_s": 1_781_449_150.5, "until_s": 1_781_449_205.75})
        );
        assert_eq!(v["defer_after_s"], json!(300.0));
        assert_eq!(stored_inputs(&row(&text)).unwrap(), inputs);
        let plain = InputsRecord::of(&expected(Observations::Through(9)))
            .to_json()
            .unwrap();
        assert!(
            !plain.contains("turn_radius_assumed")
                && !plain.contains("shown_bank")
                && !plain.contains("acceptance")
                && !plain.contains("revisit")
                && !plain.contains("captured")
                && !plain.contains("watch")
        );
    }

    #[test]
    fn damaged_inputs_are_an_internal_error_not_a_panic() {
        for bad in [
            "{\"inputs\": 1".to_string(),
            "[]".to_string(),
            old_row(",\"observation_seq\":9")
                .inputs
                .replace("avoid", "swerve"),
            old_row(",\"observation_seq\":9")
                .inputs
                .replace("telemetry", "radio"),
        ] {
            assert!(
                matches!(stored_inputs(&row(&bad)), Err(ApiError::Internal(_))),
                "{bad}"
            );
        }
    }
}
