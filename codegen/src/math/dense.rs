//! Small dense linear algebra in `f64` for the generator's numerical analyses (the spatial
//! loops' Newton iteration and their rank checks): an LU solve with partial pivoting and a
//! column-pivoted Gram–Schmidt that tells which columns of a matrix are independent, and a
//! determinant (whose sign the evaluator follows along a continuation).

/// Solves `A X = B` in place for the columns of `B` (`a` is `n × n`, `b` is `n × k`, both
/// row-major) by Gaussian elimination with partial pivoting. `None` if a pivot is not larger
/// than `1e-14` times the largest entry of `A` (singular to working precision) or not finite.
pub fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<Vec<f64>>) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let scale = a.iter().flatten().fold(0.0_f64, |m, x| m.max(x.abs()));
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    for column in 0..n {
        let pivot_row = (column..n).max_by(|&i, &j| a[i][column].abs().total_cmp(&a[j][column].abs()))?;
        let pivot = a[pivot_row][column];
        // Also refuses a NaN pivot.
        if pivot.abs().partial_cmp(&(1e-14 * scale)) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        a.swap(column, pivot_row);
        b.swap(column, pivot_row);
        let (upper, lower) = a.split_at_mut(column + 1);
        let (pivot_row_values, b_lower) = {
            let (b_upper, b_lower) = b.split_at_mut(column + 1);
            (&b_upper[column], b_lower)
        };
        for (row, b_row) in lower.iter_mut().zip(b_lower.iter_mut()) {
            let factor = row[column] / pivot;
            if factor == 0.0 {
                continue;
            }
            for (x, &above) in row[column..].iter_mut().zip(&upper[column][column..]) {
                *x -= factor * above;
            }
            for (x, &above) in b_row.iter_mut().zip(pivot_row_values) {
                *x -= factor * above;
            }
        }
    }
    for column in (0..n).rev() {
        for k in 0..b[column].len() {
            let tail: f64 = (column + 1..n).map(|j| a[column][j] * b[j][k]).sum();
            b[column][k] = (b[column][k] - tail) / a[column][column];
        }
    }
    Some(b)
}

/// The determinant of the square matrix `a` (row-major), by Gaussian elimination with
/// partial pivoting: NaN if an entry is not finite, `0.0` for an exactly singular matrix.
pub fn determinant(mut a: Vec<Vec<f64>>) -> f64 {
    let n = a.len();
    if a.iter().flatten().any(|x| !x.is_finite()) {
        return f64::NAN;
    }
    let mut det = 1.0;
    for column in 0..n {
        let Some(pivot_row) = (column..n).max_by(|&i, &j| a[i][column].abs().total_cmp(&a[j][column].abs()))
        else {
            return 0.0;
        };
        let pivot = a[pivot_row][column];
        if pivot == 0.0 {
            return 0.0;
        }
        if pivot_row != column {
            a.swap(column, pivot_row);
            det = -det;
        }
        det *= pivot;
        let (upper, lower) = a.split_at_mut(column + 1);
        for row in lower.iter_mut() {
            let factor = row[column] / pivot;
            for (x, &above) in row[column..].iter_mut().zip(&upper[column][column..]) {
                *x -= factor * above;
            }
        }
    }
    det
}

/// Which columns of the `m × n` matrix `a` (row-major) are independent, by Gram–Schmidt with
/// column pivoting: the independent columns in the order chosen (each the largest remaining
/// after the previous ones are projected out), and the rest, whose remainders are all below
/// `tolerance` times the largest column's norm.
pub fn independent_columns(a: &[Vec<f64>], tolerance: f64) -> (Vec<usize>, Vec<usize>) {
    let (m, n) = (a.len(), a.first().map_or(0, Vec::len));
    let mut columns: Vec<Vec<f64>> = (0..n).map(|j| (0..m).map(|i| a[i][j]).collect()).collect();
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let largest = columns.iter().map(|c| norm(c)).fold(0.0, f64::max);
    let mut remaining: Vec<usize> = (0..n).collect();
    let mut chosen = Vec::new();
    while !remaining.is_empty() {
        let (position, &best) = remaining
            .iter()
            .enumerate()
            .max_by(|(_, &i), (_, &j)| norm(&columns[i]).total_cmp(&norm(&columns[j])))
            .expect("not empty");
        let length = norm(&columns[best]);
        // Also stops at a NaN remainder.
        if length.partial_cmp(&(tolerance * largest)) != Some(std::cmp::Ordering::Greater) {
            break;
        }
        remaining.remove(position);
        let unit: Vec<f64> = columns[best].iter().map(|x| x / length).collect();
        for &j in &remaining {
            let dot: f64 = unit.iter().zip(&columns[j]).map(|(u, c)| u * c).sum();
            for (c, u) in columns[j].iter_mut().zip(&unit) {
                *c -= dot * u;
            }
        }
        chosen.push(best);
    }
    (chosen, remaining)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_system_that_needs_pivoting() {
        // A zero in the first pivot position: without row exchanges the elimination divides by
        // zero. Solution worked out by hand: x = (1, 2, 3).
        let a = vec![vec![0.0, 2.0, 1.0], vec![1.0, 1.0, 0.0], vec![2.0, 0.0, 3.0]];
        let b = vec![vec![7.0], vec![3.0], vec![11.0]];
        let x = solve(a, b).expect("regular");
        for (value, expected) in x.iter().map(|r| r[0]).zip([1.0, 2.0, 3.0]) {
            assert!((value - expected).abs() < 1e-14, "{value} vs {expected}");
        }
        assert!(solve(vec![vec![1.0, 2.0], vec![2.0, 4.0]], vec![vec![1.0], vec![2.0]]).is_none());
        assert!(solve(vec![vec![f64::NAN]], vec![vec![1.0]]).is_none());
    }

    #[test]
    fn finds_the_dependent_columns() {
        // Column 2 = column 0 + column 1; column 3 is independent.
        let a = vec![vec![1.0, 0.0, 1.0, 0.0], vec![0.0, 2.0, 2.0, 0.0], vec![0.0, 0.0, 0.0, 5.0]];
        let (chosen, rest) = independent_columns(&a, 1e-10);
        assert_eq!(chosen.len(), 3);
        assert_eq!(rest.len(), 1);
        assert_eq!(chosen[0], 3, "the longest column first");
        let (chosen, rest) = independent_columns(&[vec![1.0, 0.0], vec![0.0, 1.0]], 1e-10);
        assert_eq!((chosen.len(), rest.len()), (2, 0));
    }

    #[test]
    fn determinant_keeps_the_sign_of_row_exchanges() {
        // Worked out by hand: det = 0·(3 − 0) − 2·(3 − 0) + 1·(0 − 2) = −8.
        let a = vec![vec![0.0, 2.0, 1.0], vec![1.0, 1.0, 0.0], vec![2.0, 0.0, 3.0]];
        assert!((determinant(a) + 8.0).abs() < 1e-14);
        assert_eq!(determinant(vec![vec![1.0, 2.0], vec![2.0, 4.0]]), 0.0);
        assert!(determinant(vec![vec![f64::NAN]]).is_nan());
    }
}
