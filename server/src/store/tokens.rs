//! Access tokens as stored: name, role, the SHA-256 digest of the token's text (never the
//! text itself), creation and revocation times. See [`crate::auth`].

use sqlx::Row;

use super::Store;
use crate::time::{from_us, to_us};

/// A stored token (without any secret: the digest stays in the database).
#[derive(Debug, Clone, PartialEq)]
pub struct TokenRow {
    /// Its name, recorded as the writer of what it stores.
    pub name: String,
    /// `read`, `write` or `admin`.
    pub role: String,
    /// When it was created, Unix seconds.
    pub created_at_s: f64,
    /// When it was revoked, Unix seconds; `None` while it is valid.
    pub revoked_at_s: Option<f64>,
}

/// Why a token could not be created.
#[derive(Debug, thiserror::Error)]
pub enum CreateTokenError {
    /// A token (valid or revoked) already has this name: names identify writers, so a name
    /// is never reused.
    #[error(
        "a token named '{0}' already exists (revoked tokens keep their names); choose another name"
    )]
    NameTaken(String),
    /// The database failed.
    #[error(transparent)]
    Db(#[from] sqlx::Error),
}

impl Store {
    /// Stores a new token.
    ///
    /// # Errors
    /// [`CreateTokenError::NameTaken`] when the name exists; database failures.
    pub async fn create_token(
        &self,
        name: &str,
        role: &str,
        digest: &str,
        created_at_s: f64,
    ) -> Result<(), CreateTokenError> {
        let r = sqlx::query(
            "INSERT INTO tokens (name, role, digest, created_at_us) VALUES ($1, $2, $3, $4)",
        )
        .bind(name.to_string())
        .bind(role.to_string())
        .bind(digest.to_string())
        .bind(to_us(created_at_s))
        .execute(&self.write)
        .await;
        match r {
            Ok(_) => Ok(()),
            Err(e) if super::violates(&e, sqlx::error::ErrorKind::UniqueViolation) => {
                Err(CreateTokenError::NameTaken(name.to_string()))
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Every token, oldest first.
    ///
    /// # Errors
    /// Database failures.
    pub async fn list_tokens(&self) -> Result<Vec<TokenRow>, sqlx::Error> {
        let rows = sqlx::query(
            "SELECT name, role, created_at_us, revoked_at_us FROM tokens ORDER BY created_at_us, name",
        )
        .fetch_all(&self.read)
        .await?;
        rows.iter()
            .map(|r| {
                Ok(TokenRow {
                    name: r.try_get(0)?,
                    role: r.try_get(1)?,
                    created_at_s: from_us(r.try_get(2)?),
                    revoked_at_s: r.try_get::<Option<i64>, _>(3)?.map(from_us),
                })
            })
            .collect()
    }

    /// Revokes the token `name`; false when no valid token has that name.
    ///
    /// # Errors
    /// Database failures.
    pub async fn revoke_token(&self, name: &str, at_s: f64) -> Result<bool, sqlx::Error> {
        let r = sqlx::query(
            "UPDATE tokens SET revoked_at_us = $2 WHERE name = $1 AND revoked_at_us IS NULL",
        )
        .bind(name.to_string())
        .bind(to_us(at_s))
        .execute(&self.write)
        .await?;
        Ok(r.rows_affected() > 0)
    }

    /// Every valid (not revoked) token: digest, name and role.
    ///
    /// # Errors
    /// Database failures.
    pub async fn valid_tokens(&self) -> Result<Vec<(String, String, String)>, sqlx::Error> {
        sqlx::query("SELECT digest, name, role FROM tokens WHERE revoked_at_us IS NULL")
            .fetch_all(&self.read)
            .await?
            .iter()
            .map(|r| Ok((r.try_get(0)?, r.try_get(1)?, r.try_get(2)?)))
            .collect()
    }

    /// How many valid tokens exist.
    ///
    /// # Errors
    /// Database failures.
    pub async fn count_valid_tokens(&self) -> Result<i64, sqlx::Error> {
        let row = sqlx::query("SELECT COUNT(*) FROM tokens WHERE revoked_at_us IS NULL")
            .fetch_one(&self.read)
            .await?;
        row.try_get(0)
    }
}
