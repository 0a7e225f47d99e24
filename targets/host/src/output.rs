//! Writing a [`Trace`] as CSV (header row `t, q0.., qd0.., x0.., u0.., f0.., xp0..`) with the
//! `csv` crate.

use std::path::Path;

use crate::sim::Trace;

/// Writes `trace` to `path` as CSV.
pub fn write_csv(trace: &Trace, path: &Path) -> Result<(), String> {
    let fail = |e: &dyn std::fmt::Display| format!("error: cannot write {}: {e}", path.display());
    let mut writer = csv::Writer::from_path(path).map_err(|e| fail(&e))?;
    writer.write_record(&trace.columns).map_err(|e| fail(&e))?;
    for row in &trace.rows {
        writer.write_record(row.iter().map(|v| format!("{v:.9e}"))).map_err(|e| fail(&e))?;
    }
    writer.flush().map_err(|e| fail(&e))
}
