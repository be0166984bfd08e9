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

/// Columns of a plan row, as [`Store::commit_plans`] binds them.
const PLAN_COLUMNS: usize = 8;

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
        let Some(recent) = &self.recent else {
            return self.read_latest_plan_revision(mission_id).await;
        };
        if let Some(r) = recent.latest_revision(&mission_id.0) {
            return Ok(r);
        }
        let epoch = recent.epoch(&mission_id.0);
        let r = self.read_latest_plan_revision(mission_id).await?;
        recent.fill_latest_revision(&mission_id.0, epoch, r);
        Ok(r)
    }

    async fn read_latest_plan_revision(&self, mission_id: &MissionId) -> Result<i64, sqlx::Error> {
        let row = sqlx::query("SELECT COALESCE(MAX(revision), 0) FROM plans WHERE mission_id = $1")
            .bind(mission_id.to_string())
            .fetch_one(&self.read)
            .await?;
        row.try_get::<i64, _>(0)
    }

    /// Stores a plan at `row.revision`, which must be the next free revision. On SQLite
    /// the plan goes through the group commit ([`super::group_commit`]): plans arriving
    /// together are stored by one statement, so they share one commit.
    #[tracing::instrument(skip(self, row), fields(mission = %row.mission_id, revision = row.revision))]
    pub async fn insert_plan(&self, row: &PlanRow) -> Result<(), InsertPlanError> {
        let stored = self.insert_plan_any(row).await;
        if let Some(recent) = &self.recent {
            match &stored {
                Ok(()) => recent.plan_written(row),
                // The revision was another plan's: its own write told the cache.
                Err(InsertPlanError::RevisionTaken(_) | InsertPlanError::NoMission) => {}
                Err(InsertPlanError::Db(_)) => recent.plan_unknown(&row.mission_id.0),
            }
        }
        stored
    }

    async fn insert_plan_any(&self, row: &PlanRow) -> Result<(), InsertPlanError> {
        if let Some(group) = &self.group
            && let Some(result) = group.submit_plan(row).await
        {
            return result;
        }
        match &self.writer {
            Some(w) => {
                let (store, row) = (self.clone(), row.clone());
                w.run(async move { store.insert_plan_here(&row).await })
                    .await
            }
            None => self.insert_plan_here(row).await,
        }
    }

    /// Stores `rows` (plans of any missions) with one statement, so on SQLite they share
    /// one commit: a plan whose revision is already taken (by an earlier request, or by a
    /// plan earlier in `rows`: the first one wins) gets [`InsertPlanError::RevisionTaken`],
    /// one whose mission does not exist [`InsertPlanError::NoMission`], each without
    /// disturbing the others. Answers in the order of `rows`.
    ///
    /// # Errors
    /// Database failures (nothing is stored).
    pub async fn commit_plans(
        &self,
        rows: &[PlanRow],
    ) -> Result<Vec<Result<(), InsertPlanError>>, sqlx::Error> {
        if rows.is_empty() {
            return Ok(Vec::new());
        }
        let values = if self.backend == super::Backend::Sqlite {
            super::values_sql_anonymous
        } else {
            super::values_sql
        };
        let sql = values(
            "INSERT INTO plans (id, mission_id, revision, created_at_us, seed, inputs, body, written_by) SELECT * FROM (VALUES ",
            PLAN_COLUMNS,
            rows.len(),
            ") AS v WHERE EXISTS (SELECT 1 FROM missions WHERE id = v.column2) \
             ON CONFLICT DO NOTHING RETURNING id",
        );
        let mut q = sqlx::query(sqlx::AssertSqlSafe(sql));
        for row in rows {
            q = bind_plan(q, row);
        }
        let mut conn = self.write.acquire().await?;
        let stored: std::collections::HashSet<String> = q
            .fetch_all(&mut *conn)
            .await?
            .iter()
            .map(|r| r.try_get::<String, _>(0))
            .collect::<Result<_, _>>()?;
        // A plan left out had its revision taken, or no mission: ask which missions exist
        // only when some plan was left out.
        let mut missing: Vec<&str> = rows
            .iter()
            .filter(|r| !stored.contains(&r.id.0))
            .map(|r| r.mission_id.0.as_str())
            .collect();
        missing.sort_unstable();
        missing.dedup();
        let existing = super::existing_missions(&mut conn, &missing).await?;
        Ok(rows
            .iter()
            .map(|r| {
                if stored.contains(&r.id.0) {
                    Ok(())
                } else if existing.contains(&r.mission_id.0) {
                    Err(InsertPlanError::RevisionTaken(r.revision))
                } else {
                    Err(InsertPlanError::NoMission)
                }
            })
            .collect())
    }

    /// Stores one plan by itself: the path of PostgreSQL, and of a plan whose group
    /// failed.
    pub(super) async fn insert_plan_here(&self, row: &PlanRow) -> Result<(), InsertPlanError> {
        let r = bind_plan(
            sqlx::query(
                "INSERT INTO plans (id, mission_id, revision, created_at_us, seed, inputs, body, written_by) VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
            ),
            row,
        )
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
        if let Some(recent) = &self.recent
            && let Some(row) = recent.plan(&mission_id.0, revision)
        {
            return Ok(Some(row));
        }
        let row = self
            .plan_where("revision = $2", mission_id, PlanKey::Revision(revision))
            .await?;
        if let (Some(recent), Some(row)) = (&self.recent, &row) {
            recent.fill_plan(&mission_id.0, row);
        }
        Ok(row)
    }

    pub(super) async fn plan_where(
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

/// Binds one plan row's [`PLAN_COLUMNS`] columns, in the order of the plans inserts.
fn bind_plan<'q>(q: super::AnyQuery<'q>, row: &PlanRow) -> super::AnyQuery<'q> {
    q.bind(row.id.0.clone())
        .bind(row.mission_id.0.clone())
        .bind(row.revision)
        .bind(to_us(row.created_at_s))
        .bind(row.seed.to_string())
        .bind(row.inputs.clone())
        .bind(row.body.clone())
        .bind(row.written_by.clone())
}

pub(super) enum PlanKey<'a> {
    Id(&'a str),
    Revision(i64),
}
