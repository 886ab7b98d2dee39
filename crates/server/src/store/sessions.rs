//! Browser sessions: stored by the hash of their secret, each acting for
//! the token that opened it, and only while that token is live.

use sqlx::FromRow;

use super::db::{now_ms, Store};
use super::error::StoreError;
use super::kinds::Role;

#[derive(FromRow)]
struct LiveSession {
    token_id: String,
    role: Role,
}

impl Store {
    /// Opens a session for a token until `expires_at` (Unix ms), removing
    /// expired ones on the way so that the table stays the size of the
    /// sessions in use.
    pub async fn insert_session(
        &self,
        hash: &str,
        token_id: &str,
        expires_at: i64,
    ) -> Result<(), StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        sqlx::query("DELETE FROM sessions WHERE expires_at <= $1")
            .bind(now)
            .execute(&mut *tx)
            .await?;
        sqlx::query(
            "INSERT INTO sessions (hash, token_id, created_at, expires_at) VALUES ($1, $2, $3, $4)",
        )
        .bind(hash)
        .bind(token_id)
        .bind(now)
        .bind(expires_at)
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(())
    }

    /// The token id and role a live session acts for: unexpired, and its
    /// token not revoked.
    pub async fn session_role(&self, hash: &str) -> Result<Option<(String, Role)>, StoreError> {
        let row: Option<LiveSession> = sqlx::query_as(
            "SELECT t.id AS token_id, t.role FROM sessions s JOIN tokens t ON t.id = s.token_id
             WHERE s.hash = $1 AND s.expires_at > $2 AND t.revoked_at IS NULL",
        )
        .bind(hash)
        .bind(now_ms())
        .fetch_optional(&self.read)
        .await?;
        Ok(row.map(|s| (s.token_id, s.role)))
    }

    /// Ends a session (signing out); false if there was none.
    pub async fn delete_session(&self, hash: &str) -> Result<bool, StoreError> {
        let r = sqlx::query("DELETE FROM sessions WHERE hash = $1")
            .bind(hash)
            .execute(&self.write)
            .await?;
        Ok(r.rows_affected() == 1)
    }
}
