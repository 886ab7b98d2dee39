//! Record sources that need no files: a simulation regenerated on every
//! pass (tests, planning), and any in-memory slice (short runs).

use super::error::CalibError;
use super::run::RecordSource;
use crate::record::Record;
use crate::sim::{simulate, SimConfig};

/// A simulated run, generated afresh (and identically) for every pass.
pub struct SimSource(pub SimConfig);

impl RecordSource for SimSource {
    fn records(
        &self,
    ) -> Result<Box<dyn Iterator<Item = Result<Record, CalibError>> + '_>, CalibError> {
        let sim = simulate(&self.0).map_err(|e| CalibError::Source(e.to_string()))?;
        Ok(Box::new(sim.map(Ok)))
    }
}

/// Records already in memory.
pub struct SliceSource<'a>(pub &'a [Record]);

impl RecordSource for SliceSource<'_> {
    fn records(
        &self,
    ) -> Result<Box<dyn Iterator<Item = Result<Record, CalibError>> + '_>, CalibError> {
        Ok(Box::new(self.0.iter().copied().map(Ok)))
    }
}
