//! Calibration certificates: one per approved result, numbered in the
//! order they were issued (`SC-000001`, …). A certificate is made when a
//! run's current result is approved, never when a page is viewed, so a
//! number is only ever spent on a certificate that is valid, and viewing
//! it again shows the same number and date. Rows outlive their runs.

use sqlx::FromRow;

use super::db::Store;
use super::dialect::{lock_key, run_key, unit_key};
use super::error::StoreError;
use super::ids::{JobId, RunId};
use super::kinds::Role;

/// The lock key of the certificates' numbering (PostgreSQL; SQLite's
/// writes are serialised by its one write lock).
const NUMBERING_KEY: &str = "certificates:number";

/// The printed number of a certificate's sequence number.
pub fn certificate_number(seq: i64) -> String {
    format!("SC-{seq:06}")
}

/// An issued certificate.
#[derive(Clone, Debug, FromRow)]
pub struct CertificateRow {
    pub seq: i64,
    pub number: String,
    pub run_id: RunId,
    /// The result it certifies: its number among the run's results (see
    /// [`Store::result_versions`]), and its calibration job (which a run
    /// calibrated again keeps: the job alone does not name the result).
    pub result_seq: i64,
    pub job_id: JobId,
    pub unit_serial: String,
    pub issued_at: i64,
    /// The approving token's label, else its id.
    pub approved_by: String,
    pub approver_token: String,
    pub approver_role: Role,
    pub approved_at: i64,
}

/// What asking for a run's certificate to be approved came to.
#[derive(Clone, Debug)]
pub enum Approval {
    /// Issued now.
    Issued(CertificateRow),
    /// The current result was already approved: its certificate, unchanged.
    AlreadyIssued(CertificateRow),
    /// The run has no current result.
    NoResult,
    /// The current result's verdict is not `accepted` (its status, `None`
    /// when it has none).
    NotAccepted(Option<String>),
}

/// The approving caller.
#[derive(Clone, Copy, Debug)]
pub struct Approver<'a> {
    pub token_id: &'a str,
    pub role: Role,
}

const COLUMNS: &str =
    "seq, number, run_id, result_seq, job_id, unit_serial, issued_at, approved_by, \
                       approver_token, approver_role, approved_at";

/// The current result's number, job and verdict, read under the run's
/// locks.
#[derive(FromRow)]
struct Current {
    result_seq: i64,
    job_id: JobId,
    verdict: Option<String>,
}

impl Store {
    /// Approves the run's current result if its verdict is accepted: its
    /// certificate is issued with the next number. One transaction holding
    /// the run's and the unit's locks, the keys a new calibration result and
    /// a verdict judged again take, so the result and verdict approved are
    /// the ones current at the commit.
    pub async fn approve_certificate(
        &self,
        run_id: RunId,
        approver: Approver<'_>,
        now: i64,
    ) -> Result<Approval, StoreError> {
        let serial: Option<String> =
            sqlx::query_scalar("SELECT unit_serial FROM runs WHERE id = $1")
                .bind(run_id)
                .fetch_optional(&self.read)
                .await?;
        let Some(serial) = serial else {
            return Ok(Approval::NoResult);
        };
        let mut tx = self.begin_write().await?;
        lock_key(self.backend, &mut tx, &run_key(run_id)).await?;
        lock_key(self.backend, &mut tx, &unit_key(&serial)).await?;
        let current: Option<Current> = sqlx::query_as(
            "SELECT (SELECT COUNT(*) FROM superseded_results s WHERE s.run_id = $1) + 1
                        AS result_seq, job_id, verdict
                 FROM results WHERE run_id = $1",
        )
        .bind(run_id)
        .fetch_optional(&mut *tx)
        .await?;
        let Some(current) = current else {
            return Ok(Approval::NoResult);
        };
        let existing: Option<CertificateRow> = sqlx::query_as(&format!(
            "SELECT {COLUMNS} FROM certificates WHERE run_id = $1 AND result_seq = $2"
        ))
        .bind(run_id)
        .bind(current.result_seq)
        .fetch_optional(&mut *tx)
        .await?;
        if let Some(row) = existing {
            return Ok(Approval::AlreadyIssued(row));
        }
        if current.verdict.as_deref() != Some("accepted") {
            return Ok(Approval::NotAccepted(current.verdict));
        }
        lock_key(self.backend, &mut tx, NUMBERING_KEY).await?;
        let seq: i64 = sqlx::query_scalar("SELECT COALESCE(MAX(seq), 0) + 1 FROM certificates")
            .fetch_one(&mut *tx)
            .await?;
        let by: Option<String> =
            sqlx::query_scalar("SELECT COALESCE(label, id) FROM tokens WHERE id = $1")
                .bind(approver.token_id)
                .fetch_optional(&mut *tx)
                .await?;
        let row = CertificateRow {
            seq,
            number: certificate_number(seq),
            run_id,
            result_seq: current.result_seq,
            job_id: current.job_id,
            unit_serial: serial,
            issued_at: now,
            approved_by: by.unwrap_or_else(|| approver.token_id.to_string()),
            approver_token: approver.token_id.to_string(),
            approver_role: approver.role,
            approved_at: now,
        };
        sqlx::query(&format!(
            "INSERT INTO certificates ({COLUMNS}) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11)"
        ))
        .bind(row.seq)
        .bind(&row.number)
        .bind(row.run_id)
        .bind(row.result_seq)
        .bind(row.job_id)
        .bind(&row.unit_serial)
        .bind(row.issued_at)
        .bind(&row.approved_by)
        .bind(&row.approver_token)
        .bind(row.approver_role)
        .bind(row.approved_at)
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(Approval::Issued(row))
    }

    /// Every certificate issued for a run's results, oldest first (those
    /// of superseded results first; the current result's, if approved,
    /// last).
    pub async fn run_certificates(&self, run_id: RunId) -> Result<Vec<CertificateRow>, StoreError> {
        Ok(sqlx::query_as(&format!(
            "SELECT {COLUMNS} FROM certificates WHERE run_id = $1 ORDER BY seq"
        ))
        .bind(run_id)
        .fetch_all(&self.read)
        .await?)
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;
    use crate::store::NewRun;

    fn new_run(serial: &str) -> NewRun {
        NewRun::for_test(serial, 1_000, None)
    }

    async fn set_verdict(store: &Store, status: &str) {
        sqlx::query("UPDATE results SET verdict = $1")
            .bind(status)
            .execute(&store.write)
            .await
            .unwrap();
    }

    #[tokio::test]
    async fn numbers_follow_one_another_and_an_approval_is_kept() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open_for_test(&dir.path().join("c.db")).await;
        let runs = [new_run("CERT-1"), new_run("CERT-2")];
        for r in &runs {
            store
                .seed_calibrated_run(r, &BTreeMap::new())
                .await
                .unwrap();
        }
        let admin = Approver {
            token_id: "no-such-token",
            role: Role::Admin,
        };
        // Not accepted: refused, and no number spent.
        set_verdict(&store, "needs_review").await;
        let refused = store.approve_certificate(runs[0].run_id, admin, 1).await;
        assert!(
            matches!(&refused, Ok(Approval::NotAccepted(Some(s))) if s == "needs_review"),
            "{refused:?}"
        );
        set_verdict(&store, "accepted").await;
        let mut numbers = Vec::new();
        for r in &runs {
            match store.approve_certificate(r.run_id, admin, 5).await.unwrap() {
                Approval::Issued(c) => {
                    assert_eq!((c.result_seq, c.job_id), (1, r.job_id));
                    assert_eq!(c.approved_by, "no-such-token");
                    numbers.push(c.number);
                }
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(numbers, [certificate_number(1), certificate_number(2)]);
        assert_eq!(numbers[0], "SC-000001");
        // Approving again keeps the certificate as it was issued.
        match store
            .approve_certificate(runs[0].run_id, admin, 9)
            .await
            .unwrap()
        {
            Approval::AlreadyIssued(c) => {
                assert_eq!((c.number.as_str(), c.issued_at), ("SC-000001", 5))
            }
            other => panic!("{other:?}"),
        }
        let listed = store.run_certificates(runs[1].run_id).await.unwrap();
        assert_eq!(listed.len(), 1);
        assert_eq!(listed[0].number, numbers[1]);
        assert!(matches!(
            store.approve_certificate(RunId::new(), admin, 1).await,
            Ok(Approval::NoResult)
        ));
    }
}
