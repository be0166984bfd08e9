//! Who wrote what (issue 12): the `written_by` column of missions, observations and
//! telemetry, read with the rows it belongs to.

use std::collections::HashMap;

use sqlx::Row;

use super::{ObservationRow, Store, TelemetryRow, observation_row};
use crate::time::{from_us, to_us};
use wire::ids::MissionId;

impl Store {
    /// The writer of each mission (all, or the one named), by id.
    ///
    /// # Errors
    /// Database failures.
    pub async fn mission_writers(
        &self,
        id: Option<&MissionId>,
    ) -> Result<HashMap<String, String>, sqlx::Error> {
        let rows = sqlx::query("SELECT id, written_by FROM missions WHERE ($1 IS NULL OR id = $1)")
            .bind(id.map(ToString::to_string))
            .fetch_all(&self.read)
            .await?;
        rows.iter()
            .map(|r| Ok((r.try_get(0)?, r.try_get(1)?)))
            .collect()
    }

    /// [`Store::list_observations`] with each row's writer.
    ///
    /// # Errors
    /// Database failures.
    pub async fn list_observations_written(
        &self,
        mission_id: &MissionId,
        obstacle_id: Option<&str>,
        after_s: Option<f64>,
    ) -> Result<Vec<(ObservationRow, String)>, sqlx::Error> {
        let rows = sqlx::query(
            "SELECT obstacle_id, t_us, lat_deg, lon_deg, alt_msl_m, radius_m, written_by FROM obstacle_observations \
             WHERE mission_id = $1 AND ($2 IS NULL OR obstacle_id = $2) AND t_us > $3 ORDER BY t_us, obstacle_id",
        )
        .bind(mission_id.to_string())
        .bind(obstacle_id.map(str::to_string))
        .bind(after_s.map_or(i64::MIN, to_us))
        .fetch_all(&self.read)
        .await?;
        rows.iter()
            .map(|r| Ok((observation_row(r)?, r.try_get(6)?)))
            .collect()
    }

    /// [`Store::list_telemetry`] with each sample's writer.
    ///
    /// # Errors
    /// Database failures.
    pub async fn list_telemetry_written(
        &self,
        mission_id: &MissionId,
        last: Option<u32>,
    ) -> Result<Vec<(TelemetryRow, String)>, sqlx::Error> {
        let rows = sqlx::query(
            "SELECT t_us, lat_deg, lon_deg, alt_msl_m, heading_deg, speed_mps, written_by FROM aircraft_telemetry \
             WHERE mission_id = $1 ORDER BY t_us DESC LIMIT $2",
        )
        .bind(mission_id.to_string())
        .bind(i64::from(last.unwrap_or(u32::MAX)))
        .fetch_all(&self.read)
        .await?;
        let mut out = rows
            .iter()
            .map(|r| Ok((telemetry_row_at(r, 0)?, r.try_get(6)?)))
            .collect::<Result<Vec<_>, sqlx::Error>>()?;
        out.reverse();
        Ok(out)
    }
}

/// A telemetry sample from the columns `t_us, lat_deg, lon_deg, alt_msl_m, heading_deg,
/// speed_mps`, in that order from column `first`.
pub(crate) fn telemetry_row_at(
    r: &sqlx::any::AnyRow,
    first: usize,
) -> Result<TelemetryRow, sqlx::Error> {
    Ok(TelemetryRow {
        t_s: from_us(r.try_get(first)?),
        lat_deg: r.try_get(first + 1)?,
        lon_deg: r.try_get(first + 2)?,
        alt_msl_m: r.try_get(first + 3)?,
        heading_deg: r.try_get(first + 4)?,
        speed_mps: r.try_get(first + 5)?,
    })
}
