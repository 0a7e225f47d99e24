//! Rotation matrices of `f64`: about x and z, from roll–pitch–yaw angles (the URDF convention
//! `R = Rz(yaw) · Ry(pitch) · Rx(roll)`) and back, with right angles made exact.

use super::matrix::Mat3;

/// Right angles are exact: cos(π/2) evaluates to 6e-17, which would otherwise leave spurious
/// terms in every expression downstream. Entries within 1e-14 of 0 or ±1 become exactly that.
pub fn snap_entry(x: f64) -> f64 {
    if x.abs() < 1e-14 {
        0.0
    } else if (x.abs() - 1.0).abs() < 1e-14 {
        x.signum()
    } else {
        x
    }
}

/// [`snap_entry`] of every entry.
pub fn snap(m: Mat3<f64>) -> Mat3<f64> {
    m.map(|row| row.map(snap_entry))
}

/// `(sin x, cos x)` with right angles exact.
pub fn exact_sin_cos(x: f64) -> (f64, f64) {
    let (s, c) = x.sin_cos();
    (snap_entry(s), snap_entry(c))
}

/// Rotation about x, right angles exact.
pub fn rotation_x(angle: f64) -> Mat3<f64> {
    let (s, c) = exact_sin_cos(angle);
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}

/// Rotation about z, right angles exact.
pub fn rotation_z(angle: f64) -> Mat3<f64> {
    let (s, c) = exact_sin_cos(angle);
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// `R = Rz(yaw) · Ry(pitch) · Rx(roll)` of `[roll, pitch, yaw]` (not snapped).
pub fn rotation_rpy(rpy: [f64; 3]) -> Mat3<f64> {
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
}

/// Roll, pitch, yaw of a rotation matrix (the inverse of `rotation_rpy`); at gimbal lock
/// (pitch ±90°) roll and yaw turn about the same axis, and all of it goes into yaw.
pub fn rpy_of(r: &Mat3<f64>) -> [f64; 3] {
    let pitch = (-r[2][0]).atan2((r[0][0] * r[0][0] + r[1][0] * r[1][0]).sqrt());
    if (r[0][0] * r[0][0] + r[1][0] * r[1][0]).sqrt() < 1e-12 {
        return [0.0, pitch, (-r[0][1]).atan2(r[1][1])];
    }
    [r[2][1].atan2(r[2][2]), pitch, r[1][0].atan2(r[0][0])]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::matrix::{mat3_mul, transpose3, Numbers, IDENTITY};

    #[test]
    fn roll_pitch_yaw_round_trips_and_is_orthonormal() {
        for rpy in [[0.1, -0.4, 2.0], [1.2, 0.3, -0.7], [-2.5, 1.0, 0.2]] {
            let r = rotation_rpy(rpy);
            let back = rpy_of(&r);
            for k in 0..3 {
                assert!((back[k] - rpy[k]).abs() < 1e-12, "{rpy:?} → {back:?}");
            }
            let rrt = mat3_mul(&mut Numbers, &r, &transpose3(&r));
            for i in 0..3 {
                for j in 0..3 {
                    assert!((rrt[i][j] - IDENTITY[i][j]).abs() < 1e-14);
                }
            }
        }
        // Rx and Rz are the single-axis cases of the same convention.
        let (x, z) = (rotation_x(0.3), rotation_z(0.3));
        let (rx, rz) = (rotation_rpy([0.3, 0.0, 0.0]), rotation_rpy([0.0, 0.0, 0.3]));
        for i in 0..3 {
            for j in 0..3 {
                assert!((x[i][j] - rx[i][j]).abs() < 1e-15 && (z[i][j] - rz[i][j]).abs() < 1e-15);
            }
        }
        assert_eq!(snap(rotation_rpy([0.0, 0.0, std::f64::consts::FRAC_PI_2]))[0], [0.0, -1.0, 0.0]);
        // At gimbal lock the angles differ, the rotation does not.
        let locked = rotation_rpy([0.4, std::f64::consts::FRAC_PI_2, -0.7]);
        let back = rotation_rpy(rpy_of(&locked));
        for i in 0..3 {
            for j in 0..3 {
                assert!((locked[i][j] - back[i][j]).abs() < 1e-12, "entry {i}{j}");
            }
        }
    }
}
