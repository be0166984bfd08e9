//! Stored plans: one row per revision of a mission's stack, with the inputs and seed that
//! replay it and the answer (its storage record, not the API response).

use sqlx::Row;

use super::Store;
use crate::time::{from_us, to_us};
use wire::ids::{MissionId, PlanId};

/// A stored plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanRow {
    /// Plan id.
    pub id: PlanId,
    /// Mission id.
    pub mission_id: MissionId,
    /// Revision within the mission (1, 2, ...).
    pub revision: i64,
    /// When it was stored, Unix seconds.
    pub created_at_s: f64,
    /// The seed (decimal).
    pub seed: u64,
    /// The inputs, JSON.
    pub inputs: String,
    /// The answer: a plan record (`api::plan_record`), JSON; older rows hold the answer itself.
    pub body: String,
    /// The name of the token that stored it, or `local`.
    pub written_by: String,
}

/// Why a plan could not be stored.
#[derive(Debug, thiserror::Error)]
pub enum InsertPlanError {
    /// Another plan took this revision first: retry from the new latest.
    #[error("revision {0} was taken by a concurrent plan")]
    RevisionTaken(i64),
    /// The mission does not exist (any more).
    #[error("mission does not exist")]
    NoMission,
    /// The database failed.
    #[error(transparent)]
    Db(#[from] sqlx::Error),
}

impl Store {
    /// The newest revision of a mission's plans (0 when none). Read from the read pool (on
    /// SQLite it does not queue behind the single writer): a plan committed since is
    /// caught by [`Store::insert_plan`]'s unique revision (409), as before.
    #[tracing::instrument(skip(self))]
    pub async fn latest_plan_revision(&self, mission_id: &MissionId) -> Result<i64, sqlx::Error> {
        let row = sqlx::query("SELECT COALESCE(MAX(revision), 0) FROM plans WHERE mission_id = $1")
            .bind(mission_id.to_string())
            .fetch_one(&self.read)
            .await?;
        row.try_get::<i64, _>(0)
    }

    /// Stores a plan at `row.revision`, which must be the next free revision.
    #[tracing::instrument(skip(self, row), fields(mission = %row.mission_id, revision = row.revision))]
    pub async fn insert_plan(&self, row: &PlanRow) -> Result<(), InsertPlanError> {
        match &self.writer {
            Some(w) => {
                let (store, row) = (self.clone(), row.clone());
                w.run(async move { store.insert_plan_here(&row).await })
                    .await
            }
            None => self.insert_plan_here(row).await,
        }
    }

    async fn insert_plan_here(&self, row: &PlanRow) -> Result<(), InsertPlanError> {
        let r = sqlx::query(
            "INSERT INTO plans (id, mission_id, revision, created_at_us, seed, inputs, body, written_by) VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
        )
        .bind(row.id.0.clone())
        .bind(row.mission_id.0.clone())
        .bind(row.revision)
        .bind(to_us(row.created_at_s))
        .bind(row.seed.to_string())
        .bind(row.inputs.clone())
        .bind(row.body.clone())
        .bind(row.written_by.clone())
        .execute(&self.write)
        .await;
        match r {
            Ok(_) => Ok(()),
            Err(e) if super::violates(&e, sqlx::error::ErrorKind::UniqueViolation) => {
                Err(InsertPlanError::RevisionTaken(row.revision))
            }
            Err(e) if super::violates(&e, sqlx::error::ErrorKind::ForeignKeyViolation) => {
                Err(InsertPlanError::NoMission)
            }
            Err(e) => Err(e.into()),
        }
    }

    /// One plan of a mission by id.
    #[tracing::instrument(skip(self))]
    pub async fn get_plan(
        &self,
        mission_id: &MissionId,
        plan_id: &PlanId,
    ) -> Result<Option<PlanRow>, sqlx::Error> {
        self.plan_where("id = $2", mission_id, PlanKey::Id(plan_id))
            .await
    }

    /// One plan of a mission by revision.
    #[tracing::instrument(skip(self))]
    pub async fn get_plan_by_revision(
        &self,
        mission_id: &MissionId,
        revision: i64,
    ) -> Result<Option<PlanRow>, sqlx::Error> {
        self.plan_where("revision = $2", mission_id, PlanKey::Revision(revision))
            .await
    }

    async fn plan_where(
        &self,
        cond: &'static str,
        mission_id: &MissionId,
        key: PlanKey<'_>,
    ) -> Result<Option<PlanRow>, sqlx::Error> {
        let sql = match cond {
            "id = $2" => {
                "SELECT id, mission_id, revision, created_at_us, seed, inputs, body, written_by FROM plans WHERE mission_id = $1 AND id = $2"
            }
            _ => {
                "SELECT id, mission_id, revision, created_at_us, seed, inputs, body, written_by FROM plans WHERE mission_id = $1 AND revision = $2"
            }
        };
        let q = sqlx::query(sql).bind(mission_id.to_string());
        let q = match key {
            PlanKey::Id(id) => q.bind(id.to_string()),
            PlanKey::Revision(r) => q.bind(r),
        };
        let row = q.fetch_optional(&self.read).await?;
        row.map(|r| {
            Ok(PlanRow {
                id: PlanId(r.try_get(0)?),
                mission_id: MissionId(r.try_get(1)?),
                revision: r.try_get(2)?,
                created_at_s: from_us(r.try_get(3)?),
                seed: r
                    .try_get::<String, _>(4)?
                    .parse()
                    .map_err(|e| sqlx::Error::Decode(Box::new(e)))?,
                inputs: r.try_get(5)?,
                body: r.try_get(6)?,
                written_by: r.try_get(7)?,
            })
        })
        .transpose()
    }
}

enum PlanKey<'a> {
    Id(&'a str),
    Revision(i64),
}
