//! Excitation trajectory files (`hapticgen excite -o TRAJ.yaml`): a finite Fourier series per
//! actuated joint, the form the runtime plays
//! ([`hapticgen_runtime::excitation::FourierTrajectory`]).
//!
//! ```yaml
//! model: joystick_1dof          # the model's `name`; variant too where it has one
//! period: 10.0                  # s: T, the fundamental ω = 2π/T
//! ramp: 1.0                     # s: the blend from rest into the series
//! joints:
//!   - name: q
//!     offset: 0.05              # q0_j
//!     sine: [0.21, -0.05, …]    # a_jk, harmonics k = 1..H
//!     cosine: [0.1, 0.02, …]    # b_jk
//! ```
//!
//! The host evaluates the runtime's own series (one implementation of the formula) in a
//! fixed-size instance with room for any model ([`MAX_JOINTS`] joints, [`MAX_HARMONICS`]
//! harmonics; unused entries zero).

use std::path::Path;

use hapticgen_codegen::CheckedModel;
use hapticgen_runtime::excitation::{FourierTrajectory, JointReference};
use serde::{Deserialize, Serialize};

/// Most joints a trajectory file may have.
pub const MAX_JOINTS: usize = 8;
/// Most harmonics per joint.
pub const MAX_HARMONICS: usize = 12;

/// One joint's series.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSeries {
    /// The joint's name in the model.
    pub name: String,
    /// The series' mean `q0_j`, rad (m).
    pub offset: f64,
    /// `a_jk`.
    pub sine: Vec<f64>,
    /// `b_jk` (as many as `sine`).
    pub cosine: Vec<f64>,
}

/// A trajectory file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrajectoryFile {
    /// The model's `name`.
    pub model: String,
    /// The variant it was designed for, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variant: Option<String>,
    /// Period `T`, s.
    pub period: f64,
    /// Blend from rest, s.
    pub ramp: f64,
    /// One series per actuated joint, in the model's order.
    pub joints: Vec<JointSeries>,
}

/// The fixed-size series the runtime evaluates.
pub type Series = FourierTrajectory<f64, MAX_JOINTS, MAX_HARMONICS>;

impl TrajectoryFile {
    /// Reads and checks a trajectory file against `model` (joint names and order, finite
    /// numbers, harmonics); errors name the file (and line and column for YAML errors).
    pub fn read(path: &Path, model: &CheckedModel) -> Result<TrajectoryFile, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("error: {}: {e}", path.display()))?;
        let file: TrajectoryFile = serde_yaml::from_str(&text).map_err(|e| match e.location() {
            Some(at) => format!("error: {}:{}:{}: {e}", path.display(), at.line(), at.column()),
            None => format!("error: {}: {e}", path.display()),
        })?;
        file.check(model).map_err(|e| format!("error: {}: {e}", path.display()))?;
        Ok(file)
    }

    /// Checks the file against `model`.
    pub fn check(&self, model: &CheckedModel) -> Result<(), String> {
        let names: Vec<&str> = model.joints.iter().map(|j| j.name.as_str()).collect();
        let given: Vec<&str> = self.joints.iter().map(|j| j.name.as_str()).collect();
        if names != given {
            return Err(format!(
                "the trajectory's joints [{}] are not the model's [{}] (in its order)",
                given.join(", "),
                names.join(", ")
            ));
        }
        if names.len() > MAX_JOINTS {
            return Err(format!("at most {MAX_JOINTS} joints, this model has {}", names.len()));
        }
        if !(self.period.is_finite() && self.period > 0.0) {
            return Err(format!("period must be a positive number of seconds, not {}", self.period));
        }
        if !(self.ramp.is_finite() && self.ramp >= 0.0) {
            return Err(format!("ramp must be zero or a positive number of seconds, not {}", self.ramp));
        }
        for joint in &self.joints {
            if joint.sine.len() != joint.cosine.len() || joint.sine.len() > MAX_HARMONICS {
                return Err(format!(
                    "joint `{}`: sine and cosine need the same number of harmonics, at most {MAX_HARMONICS} \
                     (got {} and {})",
                    joint.name,
                    joint.sine.len(),
                    joint.cosine.len()
                ));
            }
            let all = std::iter::once(&joint.offset).chain(&joint.sine).chain(&joint.cosine);
            if let Some(bad) = all.into_iter().find(|v| !v.is_finite()) {
                return Err(format!("joint `{}`: {bad} is not a finite number", joint.name));
            }
        }
        Ok(())
    }

    /// The runtime's series of this file.
    pub fn series(&self) -> Series {
        let mut series = Series {
            period: self.period,
            ramp: self.ramp,
            offset: [0.0; MAX_JOINTS],
            sine: [[0.0; MAX_HARMONICS]; MAX_JOINTS],
            cosine: [[0.0; MAX_HARMONICS]; MAX_JOINTS],
        };
        for (j, joint) in self.joints.iter().enumerate().take(MAX_JOINTS) {
            series.offset[j] = joint.offset;
            for (k, (&a, &b)) in joint.sine.iter().zip(&joint.cosine).enumerate().take(MAX_HARMONICS) {
                series.sine[j][k] = a;
                series.cosine[j][k] = b;
            }
        }
        series
    }

    /// The reference (with the blend) at `t`, the first `joints` entries.
    pub fn reference(series: &Series, t: f64, joints: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let JointReference { position, velocity, acceleration } = series.reference(t);
        (position[..joints].to_vec(), velocity[..joints].to_vec(), acceleration[..joints].to_vec())
    }

    /// The YAML text, with a header saying what made it.
    pub fn to_yaml(&self, header: &str) -> Result<String, String> {
        let body = serde_yaml::to_string(self).map_err(|e| format!("error: {e}"))?;
        let mut text = String::new();
        for line in header.lines() {
            text.push_str("# ");
            text.push_str(line);
            text.push('\n');
        }
        text.push_str(&body);
        Ok(text)
    }
}
