//! Bearer tokens: stored by hash only, with their role.

use sqlx::FromRow;

use super::db::{now_ms, Store};
use super::dialect::lock_key;
use super::error::StoreError;
use super::kinds::Role;

#[derive(Clone, Debug, FromRow, serde::Serialize)]
pub struct TokenRow {
    pub id: String,
    pub role: Role,
    pub label: Option<String>,
    pub created_at: i64,
    pub revoked_at: Option<i64>,
}

/// A live token's id and role.
#[derive(FromRow)]
struct LiveToken {
    id: String,
    role: Role,
}

impl Store {
    pub async fn count_tokens(&self) -> Result<i64, StoreError> {
        Ok(sqlx::query_scalar("SELECT COUNT(*) FROM tokens")
            .fetch_one(&self.write)
            .await?)
    }

    pub async fn insert_token(
        &self,
        id: &str,
        hash: &str,
        role: Role,
        label: Option<&str>,
    ) -> Result<(), StoreError> {
        sqlx::query(
            "INSERT INTO tokens (id, hash, role, label, created_at) VALUES ($1, $2, $3, $4, $5)",
        )
        .bind(id)
        .bind(hash)
        .bind(role)
        .bind(label)
        .bind(now_ms())
        .execute(&self.write)
        .await?;
        Ok(())
    }

    /// Inserts the first admin token unless any token exists, atomically, so
    /// two processes starting together cannot both create one.
    pub async fn insert_first_token(&self, id: &str, hash: &str) -> Result<bool, StoreError> {
        let mut tx = self.begin_write().await?;
        lock_key(self.backend, &mut tx, "tokens:first").await?;
        let n: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM tokens")
            .fetch_one(&mut *tx)
            .await?;
        if n > 0 {
            return Ok(false);
        }
        sqlx::query(
            "INSERT INTO tokens (id, hash, role, label, created_at) VALUES ($1, $2, $3, 'first start', $4)",
        )
        .bind(id)
        .bind(hash)
        .bind(Role::Admin)
        .bind(now_ms())
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(true)
    }

    /// The id and role of a live token by its hash.
    pub async fn token_role(&self, hash: &str) -> Result<Option<(String, Role)>, StoreError> {
        let row: Option<LiveToken> =
            sqlx::query_as("SELECT id, role FROM tokens WHERE hash = $1 AND revoked_at IS NULL")
                .bind(hash)
                .fetch_optional(&self.read)
                .await?;
        Ok(row.map(|t| (t.id, t.role)))
    }

    pub async fn list_tokens(&self) -> Result<Vec<TokenRow>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT id, role, label, created_at, revoked_at FROM tokens ORDER BY created_at, id",
        )
        .fetch_all(&self.read)
        .await?)
    }

    /// Revokes a token; false if no live token has this id.
    pub async fn revoke_token(&self, id: &str) -> Result<bool, StoreError> {
        let r =
            sqlx::query("UPDATE tokens SET revoked_at = $1 WHERE id = $2 AND revoked_at IS NULL")
                .bind(now_ms())
                .bind(id)
                .execute(&self.write)
                .await?;
        Ok(r.rows_affected() == 1)
    }
}
