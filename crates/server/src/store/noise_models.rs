//! Noise models held for units: one row per unit, read by the API and
//! joined into each calibration claim of the unit's runs (`queue`).

use sqlx::FromRow;

use super::db::{now_ms, Store};
use super::error::StoreError;
use super::runs::insert_unit;
use sinscal_core::calib::{HeldNoise, HeldNoiseUse};
use sinscal_core::io::serial::UnitSerial;

/// A unit's held noise model as stored.
#[derive(Clone, Debug, FromRow)]
pub struct HeldNoiseRow {
    pub unit_serial: String,
    /// The terms as JSON (`NoiseDensity`'s form, checked when set).
    pub noise: String,
    #[sqlx(try_from = "String")]
    pub used_as: HeldNoiseUse,
    /// The token that set it.
    pub set_by: String,
    pub set_at: i64,
}

impl HeldNoiseRow {
    /// The held model, its terms read back and checked again.
    pub fn parsed(&self) -> Result<HeldNoise, StoreError> {
        HeldNoise::from_stored(&self.noise, self.used_as.as_str()).map_err(|e| {
            StoreError::Corrupt(format!("noise model of unit {}: {e}", self.unit_serial))
        })
    }
}

impl Store {
    /// The noise model held for `serial`, if one is.
    pub async fn held_noise_model(
        &self,
        serial: &UnitSerial,
    ) -> Result<Option<HeldNoiseRow>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT unit_serial, noise, used_as, set_by, set_at
             FROM unit_noise_models WHERE unit_serial = $1",
        )
        .bind(serial.as_str())
        .fetch_optional(&self.read)
        .await?)
    }

    /// Holds `held` for `serial` (the unit is created if new: a line may
    /// characterise a unit before its first calibration run), replacing
    /// any model held before; set by the token `by`.
    pub async fn hold_noise_model(
        &self,
        serial: &UnitSerial,
        held: &HeldNoise,
        by: &str,
    ) -> Result<HeldNoiseRow, StoreError> {
        let now = now_ms();
        let noise = serde_json::to_string(&held.noise)?;
        let mut tx = self.begin_write().await?;
        insert_unit(&mut tx, serial, now).await?;
        let row = sqlx::query_as(
            "INSERT INTO unit_noise_models (unit_serial, noise, used_as, set_by, set_at)
             VALUES ($1, $2, $3, $4, $5)
             ON CONFLICT (unit_serial) DO UPDATE
               SET noise = excluded.noise, used_as = excluded.used_as,
                   set_by = excluded.set_by, set_at = excluded.set_at
             RETURNING unit_serial, noise, used_as, set_by, set_at",
        )
        .bind(serial.as_str())
        .bind(noise)
        .bind(held.used_as.as_str())
        .bind(by)
        .bind(now)
        .fetch_one(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(row)
    }

    /// Lets the unit's held model go (its calibrations measure and fit
    /// their own again); false when none was held.
    pub async fn release_noise_model(&self, serial: &UnitSerial) -> Result<bool, StoreError> {
        let mut tx = self.begin_write().await?;
        let done = sqlx::query("DELETE FROM unit_noise_models WHERE unit_serial = $1")
            .bind(serial.as_str())
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(done.rows_affected() > 0)
    }
}
