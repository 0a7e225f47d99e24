//! Identification logs: the CSV every excitation run writes and `hapticgen identify` reads.
//!
//! One row per impedance tick, columns (`JOINT` the model's joint names, in its order):
//!
//! | column | unit | what |
//! |---|---|---|
//! | `time` | s | since the run started |
//! | `q_JOINT` | rad (m) | the joint angle decoded from the encoder counts |
//! | `tau_JOINT` | N·m (N) | the joint torque of the measured motor currents, `Cᵀ (k_t N η i)` |
//! | `tau_cmd_JOINT` | N·m (N) | the commanded joint torque (after the safety limits) |
//!
//! Only what a device can measure: the identification never sees the simulator's true state.

use std::path::Path;

/// One log, column by column.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IdentificationLog {
    /// The joints' names.
    pub joints: Vec<String>,
    /// `time`, s.
    pub time: Vec<f64>,
    /// `q` per sample (one entry per joint).
    pub q: Vec<Vec<f64>>,
    /// Measured joint torque per sample.
    pub tau: Vec<Vec<f64>>,
    /// Commanded joint torque per sample.
    pub tau_command: Vec<Vec<f64>>,
}

impl IdentificationLog {
    /// An empty log for `joints`.
    pub fn new(joints: Vec<String>) -> Self {
        IdentificationLog { joints, ..Default::default() }
    }

    /// Appends one sample.
    pub fn push(&mut self, time: f64, q: &[f64], tau: &[f64], tau_command: &[f64]) {
        self.time.push(time);
        self.q.push(q.to_vec());
        self.tau.push(tau.to_vec());
        self.tau_command.push(tau_command.to_vec());
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// `true` without samples.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// The header row.
    fn header(&self) -> Vec<String> {
        let mut header = vec!["time".to_string()];
        for prefix in ["q", "tau", "tau_cmd"] {
            header.extend(self.joints.iter().map(|j| format!("{prefix}_{j}")));
        }
        header
    }

    /// Writes the CSV (nothing is left behind on failure but what the file system wrote).
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let fail = |e: &dyn std::fmt::Display| format!("error: {}: {e}", path.display());
        let mut writer = csv::Writer::from_path(path).map_err(|e| fail(&e))?;
        writer.write_record(self.header()).map_err(|e| fail(&e))?;
        for i in 0..self.len() {
            let mut row = vec![format!("{}", self.time[i])];
            for values in [&self.q[i], &self.tau[i], &self.tau_command[i]] {
                row.extend(values.iter().map(|v| format!("{v}")));
            }
            writer.write_record(&row).map_err(|e| fail(&e))?;
        }
        writer.flush().map_err(|e| fail(&e))
    }

    /// Reads a log of a model with `joints`; errors name the file, and the line of a bad value.
    pub fn read(path: &Path, joints: &[String]) -> Result<IdentificationLog, String> {
        let display = path.display();
        let mut reader = csv::Reader::from_path(path).map_err(|e| format!("error: {display}: {e}"))?;
        let header: Vec<String> = reader
            .headers()
            .map_err(|e| format!("error: {display}:1: {e}"))?
            .iter()
            .map(|h| h.trim().to_string())
            .collect();
        let find = |name: &str| {
            header.iter().position(|h| h == name).ok_or_else(|| {
                format!("error: {display}:1: no column `{name}` (the header has: {})", header.join(", "))
            })
        };
        let time = find("time")?;
        let column = |prefix: &str| {
            joints.iter().map(|j| find(&format!("{prefix}_{j}"))).collect::<Result<Vec<_>, _>>()
        };
        let (q, tau, tau_cmd) = (column("q")?, column("tau")?, column("tau_cmd")?);
        let mut log = IdentificationLog::new(joints.to_vec());
        for (row, record) in reader.records().enumerate() {
            let line = row + 2;
            let record = record.map_err(|e| format!("error: {display}:{line}: {e}"))?;
            let value = |index: usize| -> Result<f64, String> {
                let text = record.get(index).unwrap_or("").trim();
                let value: f64 = text.parse().map_err(|_| {
                    format!("error: {display}:{line}: column `{}`: `{text}` is not a number", header[index])
                })?;
                if value.is_finite() {
                    Ok(value)
                } else {
                    Err(format!("error: {display}:{line}: column `{}`: {text} is not finite", header[index]))
                }
            };
            let pick =
                |indices: &[usize]| indices.iter().map(|&i| value(i)).collect::<Result<Vec<f64>, String>>();
            let t = value(time)?;
            if let Some(&last) = log.time.last() {
                if t <= last {
                    return Err(format!(
                        "error: {display}:{line}: time {t} does not increase (the row before: {last})"
                    ));
                }
            }
            log.push(t, &pick(&q)?, &pick(&tau)?, &pick(&tau_cmd)?);
        }
        Ok(log)
    }
}
