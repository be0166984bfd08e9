//! The interop gateway's tables (migration `0015_interop.sql`): linked missions, the
//! forwarding queue's acknowledgements, and interop numbers of jink missions.

use sqlx::Row;

use crate::store::{Store, TelemetryRow};
use crate::time::to_us;
use wire::ids::MissionId;

/// Interop numbers given to missions without an interop id start above this (judges'
/// mission ids are small integers).
pub const NUMBER_BASE: i64 = 1_000_000;

/// A telemetry sample waiting to go upstream.
#[derive(Debug, Clone)]
pub struct Pending {
    /// Its mission.
    pub mission_id: MissionId,
    /// The stored sample (its time is its key).
    pub sample: TelemetryRow,
}

/// What became of a forwarded sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// The upstream server acknowledged it.
    Sent,
    /// The upstream server refused it for good (400/422); it is not sent again.
    Rejected,
}

const PENDING_FROM: &str = "FROM aircraft_telemetry a \
     JOIN interop_links l ON l.mission_id = a.mission_id \
     LEFT JOIN interop_forwarded f ON f.mission_id = a.mission_id AND f.t_us = a.t_us \
     WHERE f.mission_id IS NULL";

impl Store {
    /// The newest mission linked to upstream mission `upstream_mission` that still exists.
    pub async fn linked_mission(
        &self,
        upstream_mission: i64,
    ) -> Result<Option<MissionId>, sqlx::Error> {
        let row = sqlx::query(
            "SELECT l.mission_id FROM interop_links l JOIN missions m ON m.id = l.mission_id \
             WHERE l.upstream_mission = $1 ORDER BY l.linked_at_us DESC, l.mission_id DESC LIMIT 1",
        )
        .bind(upstream_mission)
        .fetch_optional(self.read_pool())
        .await?;
        row.map(|r| r.try_get::<String, _>(0).map(MissionId::from))
            .transpose()
    }

    /// Records that `mission_id` mirrors `upstream_mission` of `upstream_url`.
    pub async fn insert_link(
        &self,
        mission_id: &MissionId,
        upstream_url: &str,
        upstream_mission: i64,
        at_s: f64,
    ) -> Result<(), sqlx::Error> {
        sqlx::query(
            "INSERT INTO interop_links (mission_id, upstream_url, upstream_mission, linked_at_us) \
             VALUES ($1, $2, $3, $4) ON CONFLICT DO NOTHING",
        )
        .bind(mission_id.to_string())
        .bind(upstream_url.to_string())
        .bind(upstream_mission)
        .bind(to_us(at_s))
        .execute(self.write_pool())
        .await
        .map(|_| ())
    }

    /// Up to `limit` samples of linked missions not yet forwarded, in the order they were
    /// accepted.
    pub async fn pending_telemetry(&self, limit: i64) -> Result<Vec<Pending>, sqlx::Error> {
        let sql = format!(
            "SELECT a.mission_id, a.t_us, a.lat_deg, a.lon_deg, a.alt_msl_m, a.heading_deg, a.speed_mps \
             {PENDING_FROM} ORDER BY a.received_at_us, a.t_us, a.mission_id LIMIT $1"
        );
        let rows = sqlx::query(sqlx::AssertSqlSafe(sql))
            .bind(limit)
            .fetch_all(self.read_pool())
            .await?;
        rows.iter()
            .map(|r| {
                Ok(Pending {
                    mission_id: MissionId::from(r.try_get::<String, _>(0)?),
                    sample: crate::store::writers::telemetry_row_at(r, 1)?,
                })
            })
            .collect()
    }

    /// How many samples wait to be forwarded.
    pub async fn pending_count(&self) -> Result<i64, sqlx::Error> {
        let sql = format!("SELECT COUNT(*) {PENDING_FROM}");
        sqlx::query(sqlx::AssertSqlSafe(sql))
            .fetch_one(self.read_pool())
            .await?
            .try_get(0)
    }

    /// Records what became of a forwarded sample (it leaves the queue).
    pub async fn mark_forwarded(
        &self,
        p: &Pending,
        outcome: Outcome,
        at_s: f64,
    ) -> Result<(), sqlx::Error> {
        sqlx::query(
            "INSERT INTO interop_forwarded (mission_id, t_us, outcome, at_us) VALUES ($1, $2, $3, $4) \
             ON CONFLICT DO NOTHING",
        )
        .bind(p.mission_id.to_string())
        .bind(to_us(p.sample.t_s))
        .bind(match outcome {
            Outcome::Sent => "sent",
            Outcome::Rejected => "rejected",
        })
        .bind(to_us(at_s))
        .execute(self.write_pool())
        .await
        .map(|_| ())
    }

    /// The interop number of a mission without an interop id of its own (given on first
    /// use, kept thereafter).
    pub async fn interop_number(&self, mission_id: &MissionId) -> Result<i64, sqlx::Error> {
        sqlx::query("INSERT INTO interop_numbers (mission_id) VALUES ($1) ON CONFLICT DO NOTHING")
            .bind(mission_id.to_string())
            .execute(self.write_pool())
            .await?;
        let seq: i64 = sqlx::query("SELECT seq FROM interop_numbers WHERE mission_id = $1")
            .bind(mission_id.to_string())
            .fetch_one(self.write_pool())
            .await?
            .try_get(0)?;
        Ok(NUMBER_BASE + seq)
    }

    /// The mission that was given interop number `number`, if any.
    pub async fn mission_of_number(&self, number: i64) -> Result<Option<MissionId>, sqlx::Error> {
        let row = sqlx::query("SELECT mission_id FROM interop_numbers WHERE seq = $1")
            .bind(number - NUMBER_BASE)
            .fetch_optional(self.read_pool())
            .await?;
        row.map(|r| r.try_get::<String, _>(0).map(MissionId::from))
            .transpose()
    }
}
