//! The `transmission` section: couplings between the actuated joints and their drives,
//! `a = C q` (what each drive's output turns per joint coordinate), checked to be invertible
//! so that the joints follow from the drives' encoders, `q = C⁻¹ a`.

use super::{key, Resolver};
use crate::math::dense;
use crate::model::schema::ModelFile;
use crate::model::types::{Coupling, ResolvedJoint};

/// `C` and `C⁻¹`, or `None` when the file has no `transmission`. A row not written is the
/// identity's: that joint's drive turns it alone.
pub(super) fn transmission(
    r: &mut Resolver<'_, '_>,
    file: &ModelFile,
    joints: &[ResolvedJoint],
) -> Option<Coupling> {
    if file.transmission.is_empty() {
        return None;
    }
    let n = joints.len();
    let index_of = |name: &str| joints.iter().position(|j| j.name == name);
    let actuated = || joints.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(", ");
    let identity: Vec<Vec<f64>> =
        (0..n).map(|a| (0..n).map(|b| if a == b { 1.0 } else { 0.0 }).collect()).collect();
    let mut drive_from_joint = identity.clone();
    let mut complete = true;
    for (drive_joint, turns) in &file.transmission {
        let Some(row) = index_of(drive_joint) else {
            r.key_error_hint(
                &[key("transmission"), key(drive_joint)],
                format!("`{drive_joint}` is not an actuated joint: a row names the joint whose drive it describes"),
                format!("actuated joints: {}", actuated()),
            );
            complete = false;
            continue;
        };
        if turns.is_empty() {
            r.error(&[key("transmission"), key(drive_joint)], "the drive turns no joint: name at least one");
            complete = false;
        }
        drive_from_joint[row] = vec![0.0; n];
        for (joint, &ratio) in turns {
            let at = [key("transmission"), key(drive_joint), key(joint)];
            match index_of(joint) {
                None => {
                    r.key_error_hint(
                        &at,
                        format!("`{joint}` is not an actuated joint"),
                        format!("actuated joints: {}", actuated()),
                    );
                    complete = false;
                }
                Some(_) if !ratio.is_finite() => {
                    r.error(&at, format!("must be a finite number, got {ratio}"));
                    complete = false;
                }
                Some(column) => drive_from_joint[row][column] = ratio,
            }
        }
    }
    if !complete {
        return None;
    }
    match dense::solve(drive_from_joint.clone(), identity) {
        Some(joint_from_drive) => Some(Coupling { drive_from_joint, joint_from_drive }),
        None => {
            r.key_error_hint(
                &[key("transmission")],
                "the drives' outputs do not determine the joints: the coupling matrix is singular",
                "each drive must add a combination of joint angles the others do not make",
            );
            None
        }
    }
}
