//! Eigenvalues of symmetric matrices: in closed form for 3 × 3 (inertia tensors, checked at
//! load time) and by Jacobi rotations for any small size (task-space damping).

/// Eigenvalues of a symmetric 3×3 matrix, ascending, in closed form (the trigonometric
/// solution of the characteristic cubic): exact for the diagonal case, no iteration.
pub fn symmetric_eigenvalues_3x3(m: [[f64; 3]; 3]) -> [f64; 3] {
    let p1 = m[0][1].powi(2) + m[0][2].powi(2) + m[1][2].powi(2);
    if p1 == 0.0 {
        let mut e = [m[0][0], m[1][1], m[2][2]];
        e.sort_by(|a, b| a.total_cmp(b));
        return e;
    }
    let q = (m[0][0] + m[1][1] + m[2][2]) / 3.0;
    let p2 = (m[0][0] - q).powi(2) + (m[1][1] - q).powi(2) + (m[2][2] - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let mut b = m;
    for (i, row) in b.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = (m[i][j] - if i == j { q } else { 0.0 }) / p;
        }
    }
    let det_b = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1])
        - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
        + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    let r = (det_b / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let e1 = q + 2.0 * p * phi.cos();
    let e3 = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    let e2 = 3.0 * q - e1 - e3;
    let mut e = [e1, e2, e3];
    e.sort_by(|a, b| a.total_cmp(b));
    e
}

/// Eigenvalues of a small symmetric matrix of any size by cyclic Jacobi rotations (at most
/// 100 sweeps, until the off-diagonal part is negligible), in diagonal order.
pub fn symmetric_eigenvalues(mut a: Vec<Vec<f64>>) -> Vec<f64> {
    let n = a.len();
    for _ in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        let diag: f64 = (0..n).map(|i| a[i][i] * a[i][i]).sum();
        if off <= 1e-30 * diag.max(1e-300) {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for row in a.iter_mut() {
                    let (akp, akq) = (row[p], row[q]);
                    row[p] = c * akp - s * akq;
                    row[q] = s * akp + c * akq;
                }
                let (row_p, row_q) = (a[p].clone(), a[q].clone());
                for (k, (apk, aqk)) in row_p.into_iter().zip(row_q).enumerate() {
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
            }
        }
    }
    (0..n).map(|i| a[i][i]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_methods_agree_on_a_full_symmetric_matrix() {
        let m = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 1.0]];
        let closed = symmetric_eigenvalues_3x3(m);
        let mut jacobi = symmetric_eigenvalues(m.iter().map(|r| r.to_vec()).collect());
        jacobi.sort_by(|a, b| a.total_cmp(b));
        for k in 0..3 {
            assert!((closed[k] - jacobi[k]).abs() < 1e-12, "{closed:?} vs {jacobi:?}");
        }
        // Trace and determinant are the sum and product of the eigenvalues.
        assert!((closed.iter().sum::<f64>() - 8.0).abs() < 1e-12);
        let det = 4.0 * (3.0 * 1.0 - 0.04) - 1.0 * (1.0 - 0.1) + 0.5 * (0.2 - 1.5);
        assert!((closed.iter().product::<f64>() - det).abs() < 1e-12);
    }
}
