//! Product types: their limits, every revision of them, and the verdicts
//! judged again in the same transaction as a change.

use sqlx::FromRow;

use super::db::{now_ms, Store, WriteTx};
use super::dialect::{lock_key, product_key, Backend};
use super::error::StoreError;
use super::verdicts::refresh_product;
use sinscal_core::accept::ProductLimits;
use sinscal_core::calib::ErrorModel;

/// A product type as stored.
#[derive(Clone, Debug, FromRow)]
pub struct ProductTypeRow {
    pub name: String,
    pub description: Option<String>,
    /// The limits as JSON (`accept::ProductLimits`'s form).
    pub limits: String,
    /// The error model its line calibrates with (`ErrorModel`'s spelling;
    /// `None`: the server's).
    pub model: Option<String>,
    pub revision: i64,
    pub created_at: i64,
    pub updated_at: i64,
}

impl ProductTypeRow {
    /// The limits, validated again by the library.
    pub fn parsed_limits(&self) -> Result<ProductLimits, StoreError> {
        let value: serde_json::Value = serde_json::from_str(&self.limits)?;
        ProductLimits::from_json(&value, "limits")
            .map_err(|e| StoreError::Corrupt(format!("product type {}: {e}", self.name)))
    }

    /// The line's error model, parsed (`None`: the server's).
    pub fn parsed_model(&self) -> Result<Option<ErrorModel>, StoreError> {
        self.model
            .as_deref()
            .map(|m| {
                m.parse()
                    .map_err(|e| StoreError::Corrupt(format!("product type {}: {e}", self.name)))
            })
            .transpose()
    }
}

/// What a product type's new version says.
#[derive(Clone, Copy, Debug)]
pub struct ProductTypeChange<'a> {
    pub name: &'a str,
    pub description: Option<&'a str>,
    pub limits: &'a ProductLimits,
    /// The error model the line's calibrations carry (`None`: the
    /// server's).
    pub model: Option<&'a ErrorModel>,
    /// The token making the change, kept with the revision.
    pub by: &'a str,
}

const COLUMNS: &str = "name, description, limits, model, revision, created_at, updated_at";

impl Store {
    pub async fn list_product_types(&self) -> Result<Vec<ProductTypeRow>, StoreError> {
        Ok(sqlx::query_as(&format!(
            "SELECT {COLUMNS} FROM product_types ORDER BY name"
        ))
        .fetch_all(&self.read)
        .await?)
    }

    pub async fn get_product_type(&self, name: &str) -> Result<Option<ProductTypeRow>, StoreError> {
        Ok(sqlx::query_as(&format!(
            "SELECT {COLUMNS} FROM product_types WHERE name = $1"
        ))
        .bind(name)
        .fetch_optional(&self.read)
        .await?)
    }

    /// Creates a product type (its first revision, or the next after a
    /// deletion) and judges again the results of runs naming it. `None`:
    /// one of that name exists, nothing written.
    pub async fn create_product_type(
        &self,
        change: ProductTypeChange<'_>,
    ) -> Result<Option<ProductTypeRow>, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        lock_key(self.backend, &mut tx, &product_key(change.name)).await?;
        let limits = serde_json::to_string(change.limits)?;
        let revision = next_revision(&mut tx, change.name).await?;
        let created = sqlx::query(
            "INSERT INTO product_types (name, description, limits, model, revision, created_at, updated_at)
             VALUES ($1, $2, $3, $4, $5, $6, $6) ON CONFLICT (name) DO NOTHING",
        )
        .bind(change.name)
        .bind(change.description)
        .bind(&limits)
        .bind(change.model.map(ErrorModel::to_string))
        .bind(revision)
        .bind(now)
        .execute(&mut *tx)
        .await?;
        if created.rows_affected() == 0 {
            return Ok(None);
        }
        let row =
            record_revision(self.backend, &mut tx, &change, Some(&limits), revision, now).await?;
        tx.commit().await?;
        Ok(row)
    }

    /// Replaces a product type's description and limits (a new revision)
    /// and judges again the results of runs naming it. `None`: no such
    /// product type.
    pub async fn update_product_type(
        &self,
        change: ProductTypeChange<'_>,
    ) -> Result<Option<ProductTypeRow>, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        lock_key(self.backend, &mut tx, &product_key(change.name)).await?;
        let limits = serde_json::to_string(change.limits)?;
        let revision = next_revision(&mut tx, change.name).await?;
        let updated = sqlx::query(
            "UPDATE product_types SET description = $1, limits = $2, model = $3, revision = $4,
                    updated_at = $5
             WHERE name = $6",
        )
        .bind(change.description)
        .bind(&limits)
        .bind(change.model.map(ErrorModel::to_string))
        .bind(revision)
        .bind(now)
        .bind(change.name)
        .execute(&mut *tx)
        .await?;
        if updated.rows_affected() == 0 {
            return Ok(None);
        }
        let row =
            record_revision(self.backend, &mut tx, &change, Some(&limits), revision, now).await?;
        tx.commit().await?;
        Ok(row)
    }

    /// Deletes a product type (recorded as a revision without limits); the
    /// results of runs naming it are judged again, as naming an unknown
    /// product. False: no such product type.
    pub async fn delete_product_type(&self, name: &str, by: &str) -> Result<bool, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        lock_key(self.backend, &mut tx, &product_key(name)).await?;
        let deleted = sqlx::query("DELETE FROM product_types WHERE name = $1")
            .bind(name)
            .execute(&mut *tx)
            .await?;
        if deleted.rows_affected() == 0 {
            return Ok(false);
        }
        let revision = next_revision(&mut tx, name).await?;
        sqlx::query(
            "INSERT INTO product_type_revisions (name, revision, description, limits, changed_at, changed_by)
             VALUES ($1, $2, NULL, NULL, $3, $4)",
        )
        .bind(name)
        .bind(revision)
        .bind(now)
        .bind(by)
        .execute(&mut *tx)
        .await?;
        refresh_product(self.backend, &mut tx, name, now).await?;
        tx.commit().await?;
        Ok(true)
    }
}

/// The next revision of a name: one past any it ever had.
async fn next_revision(tx: &mut WriteTx, name: &str) -> Result<i64, StoreError> {
    let last: Option<i64> =
        sqlx::query_scalar("SELECT MAX(revision) FROM product_type_revisions WHERE name = $1")
            .bind(name)
            .fetch_one(&mut **tx)
            .await?;
    Ok(last.unwrap_or(0) + 1)
}

/// Keeps the revision, judges again the verdicts it touches, and reads the
/// product type back.
async fn record_revision(
    backend: Backend,
    tx: &mut WriteTx,
    change: &ProductTypeChange<'_>,
    limits: Option<&str>,
    revision: i64,
    now: i64,
) -> Result<Option<ProductTypeRow>, StoreError> {
    sqlx::query(
        "INSERT INTO product_type_revisions (name, revision, description, limits, model, changed_at,
                                             changed_by)
         VALUES ($1, $2, $3, $4, $5, $6, $7)",
    )
    .bind(change.name)
    .bind(revision)
    .bind(change.description)
    .bind(limits)
    .bind(change.model.map(ErrorModel::to_string))
    .bind(now)
    .bind(change.by)
    .execute(&mut **tx)
    .await?;
    refresh_product(backend, tx, change.name, now).await?;
    Ok(sqlx::query_as(&format!(
        "SELECT {COLUMNS} FROM product_types WHERE name = $1"
    ))
    .bind(change.name)
    .fetch_optional(&mut **tx)
    .await?)
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;
    use crate::store::{NewRun, RunDeletion, RunId, UnitFilter};
    use sinscal_core::accept::{LimitKind, ReviewReason, VerdictStatus};
    use sinscal_core::calib::ParameterEstimate;
    use sinscal_core::model::PARAMETERS;

    /// Seeds a calibrated run of `serial` naming `product`, every parameter
    /// at `value` ± 0.01 σ.
    async fn seed(store: &Store, serial: &str, product: Option<&str>, k: i64, value: f64) -> RunId {
        let params: BTreeMap<String, ParameterEstimate> = PARAMETERS
            .iter()
            .map(|p| {
                let e = ParameterEstimate {
                    value,
                    sigma: 0.01,
                    unit: p.unit.into(),
                };
                (p.name.to_string(), e)
            })
            .collect();
        let new = NewRun::for_test(serial, 1_000 * k, product);
        store.seed_calibrated_run(&new, &params).await.unwrap();
        new.run_id
    }

    async fn status(store: &Store, run: &RunId) -> (VerdictStatus, Option<i64>) {
        let v = store.get_run(*run).await.unwrap().unwrap().verdict();
        let v = v.unwrap().unwrap();
        (v.status(), v.revision)
    }

    async fn units(store: &Store, verdict: VerdictStatus) -> Vec<String> {
        let filter = UnitFilter {
            verdict: Some(verdict),
            product: None,
            serial_contains: None,
        };
        let (_, rows) = store.list_units(&filter, 10, 0).await.unwrap();
        rows.into_iter().map(|u| u.serial.to_string()).collect()
    }

    /// Verdicts follow the product type through creation, a change of its
    /// limits and deletion, history by history; repeatability counts the
    /// runs up to each one, and a deletion judges the later ones again.
    #[tokio::test]
    async fn verdicts_follow_the_product_type_and_the_history() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open_for_test(&dir.path().join("p.db")).await;
        let a1 = seed(&store, "A", Some("P1"), 1, 1.0).await;
        let a2 = seed(&store, "A", Some("P1"), 2, 1.2).await;
        let b1 = seed(&store, "B", None, 1, 5.0).await;
        // P1 has no product type yet: an unknown product needs review.
        assert_eq!(status(&store, &a2).await.0, VerdictStatus::NeedsReview);
        assert_eq!(status(&store, &b1).await.0, VerdictStatus::Accepted);

        let mut limits = ProductLimits::default();
        limits
            .set("gyro_bias_x", LimitKind::MaxAbsValue, 2.0)
            .unwrap();
        limits
            .set("gyro_bias_x", LimitKind::MaxRepeatability, 0.5)
            .unwrap();
        fn change(limits: &ProductLimits) -> ProductTypeChange<'_> {
            ProductTypeChange {
                name: "P1",
                description: Some("test"),
                limits,
                model: None,
                by: "admin",
            }
        }
        let row = store.create_product_type(change(&limits)).await.unwrap();
        assert_eq!(row.unwrap().revision, 1);
        assert!(store
            .create_product_type(change(&limits))
            .await
            .unwrap()
            .is_none());
        // One run cannot judge repeatability; two within the bound can.
        let first = store.get_run(a1).await.unwrap().unwrap().verdict();
        assert_eq!(
            first.unwrap().unwrap().verdict.reasons(),
            [ReviewReason::TooFewRuns { runs: 1, needed: 2 }]
        );
        assert_eq!(
            status(&store, &a2).await,
            (VerdictStatus::Accepted, Some(1))
        );
        assert_eq!(units(&store, VerdictStatus::Accepted).await, ["A", "B"]);

        // Tighter: sd(1.0, 1.2) = 0.141 > 0.1.
        limits
            .set("gyro_bias_x", LimitKind::MaxRepeatability, 0.1)
            .unwrap();
        store.update_product_type(change(&limits)).await.unwrap();
        assert_eq!(
            status(&store, &a2).await,
            (VerdictStatus::Rejected, Some(2))
        );
        assert_eq!(units(&store, VerdictStatus::Rejected).await, ["A"]);
        let (total, rows) = store
            .history(
                &"A".parse().unwrap(),
                (i64::MIN, i64::MAX),
                Some(VerdictStatus::Rejected),
                10,
                0,
            )
            .await
            .unwrap();
        assert_eq!((total, rows[0].run_id), (1, a2));

        // A third run judged on all three; deleting the first judges it
        // again on two.
        let a3 = seed(&store, "A", Some("P1"), 3, 1.25).await;
        assert_eq!(status(&store, &a3).await.0, VerdictStatus::Rejected);
        let deleted = store.delete_run(a1).await.unwrap();
        assert!(matches!(deleted, RunDeletion::Deleted { .. }));
        assert_eq!(status(&store, &a3).await.0, VerdictStatus::Accepted);
        let filter = UnitFilter {
            verdict: None,
            product: Some("P1".into()),
            serial_contains: None,
        };
        let (total, _) = store.list_units(&filter, 10, 0).await.unwrap();
        assert_eq!(total, 1);

        assert!(store.delete_product_type("P1", "admin").await.unwrap());
        assert_eq!(
            status(&store, &a3).await,
            (VerdictStatus::NeedsReview, None)
        );
        let again = store.create_product_type(change(&limits)).await.unwrap();
        assert_eq!(again.unwrap().revision, 4);
        store.close().await;
    }
}
