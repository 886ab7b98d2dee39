//! A run's results over time: the current one lives in `results`; every
//! one it replaced (a model adopted from a diagnosis, a calibration asked
//! for again) is kept in `superseded_results`, numbered from 1 in the
//! order they were replaced, so nothing a certificate was once made from
//! is lost.

use sqlx::FromRow;

use super::db::{Store, WriteTx};
use super::document::Stored;
use super::error::StoreError;
use super::ids::{JobId, RunId};
use super::kinds::OptionalFlag;
use sinscal_core::calib::CalibrationResult;

/// One of a run's results, current or superseded, without its document.
#[derive(Clone, Debug, FromRow)]
pub struct ResultVersion {
    /// Its number among the run's results: 1 the first made; the current
    /// one is the last.
    pub seq: i64,
    pub job_id: JobId,
    /// The model it was made with (`None`: stored before models were
    /// recorded and without one in its document).
    pub model: Option<String>,
    pub completed_at: i64,
    /// When a newer result replaced it; `None` for the current one.
    pub superseded_at: Option<i64>,
    /// Its verdict's status when it was replaced (or now, when current).
    pub verdict: Option<String>,
    #[sqlx(try_from = "OptionalFlag")]
    pub model_adequate: Option<bool>,
}

impl ResultVersion {
    pub fn is_current(&self) -> bool {
        self.superseded_at.is_none()
    }
}

/// Moves a run's current result (if any) into `superseded_results` as its
/// next number, and removes it from `results` and `result_documents`.
/// Inside the caller's transaction, which holds the run's and the unit's
/// locks; the caller judges the unit's verdicts again.
pub(super) async fn supersede_current(
    tx: &mut WriteTx,
    run_id: RunId,
    now: i64,
) -> Result<(), StoreError> {
    sqlx::query(
        "INSERT INTO superseded_results (run_id, seq, job_id, model, completed_at,
                                         superseded_at, verdict, model_adequate, result)
         SELECT r.run_id,
                (SELECT COALESCE(MAX(s.seq), 0) + 1 FROM superseded_results s
                 WHERE s.run_id = r.run_id),
                r.job_id, r.model, r.completed_at, $2, r.verdict, r.model_adequate, d.result
         FROM results r JOIN result_documents d ON d.run_id = r.run_id
         WHERE r.run_id = $1",
    )
    .bind(run_id)
    .bind(now)
    .execute(&mut **tx)
    .await?;
    for sql in [
        "DELETE FROM result_documents WHERE run_id = $1",
        "DELETE FROM results WHERE run_id = $1",
    ] {
        sqlx::query(sql).bind(run_id).execute(&mut **tx).await?;
    }
    Ok(())
}

impl Store {
    /// Every result a run has had, oldest first; the current one (if the
    /// run has one) last, numbered after the superseded ones.
    pub async fn result_versions(&self, run_id: RunId) -> Result<Vec<ResultVersion>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT seq, job_id, model, completed_at, superseded_at, verdict, model_adequate
             FROM superseded_results WHERE run_id = $1
             UNION ALL
             SELECT (SELECT COUNT(*) FROM superseded_results s WHERE s.run_id = $1) + 1,
                    job_id, model, completed_at, NULL, verdict, model_adequate
             FROM results WHERE run_id = $1
             ORDER BY 1",
        )
        .bind(run_id)
        .fetch_all(&self.read)
        .await?)
    }

    /// A run's result number `seq` (see [`Store::result_versions`]): a
    /// superseded one, or the current one when `seq` is its number.
    pub async fn result_version(
        &self,
        run_id: RunId,
        seq: i64,
    ) -> Result<Option<Stored<CalibrationResult>>, StoreError> {
        let json: Option<String> = sqlx::query_scalar(
            "SELECT result FROM superseded_results WHERE run_id = $1 AND seq = $2
             UNION ALL
             SELECT d.result FROM result_documents d
             WHERE d.run_id = $1
               AND $2 = (SELECT COUNT(*) FROM superseded_results s WHERE s.run_id = $1) + 1",
        )
        .bind(run_id)
        .bind(seq)
        .fetch_optional(&self.read)
        .await?;
        Ok(json.map(Stored::new))
    }
}
