//! Matrix products, sums and transposes over any [`Arithmetic`]: `f64` ([`Numbers`]), the
//! polynomials of [`crate::sym::poly`] and the nodes of [`crate::sym::dag`]. Each arithmetic
//! keeps its own order of operations in [`Arithmetic::dot`] (a polynomial sum is one canonical
//! merge, a DAG sum a left fold), so the helpers change no result of the code they replaced.

/// The operations a matrix helper needs, with whatever context the values live in.
pub trait Arithmetic {
    /// A scalar: a number, a polynomial or a DAG node.
    type Value: Clone;
    /// `a + b`.
    fn add(&mut self, a: &Self::Value, b: &Self::Value) -> Self::Value;
    /// `Σ_k a_k b_k` over the pairs, in this arithmetic's order.
    fn dot<'v>(&mut self, pairs: impl Iterator<Item = (&'v Self::Value, &'v Self::Value)>) -> Self::Value
    where
        Self::Value: 'v;
}

/// Plain `f64` arithmetic (`Σ` as `Iterator::sum` of the products).
pub struct Numbers;

impl Arithmetic for Numbers {
    type Value = f64;

    fn add(&mut self, a: &f64, b: &f64) -> f64 {
        a + b
    }

    fn dot<'v>(&mut self, pairs: impl Iterator<Item = (&'v f64, &'v f64)>) -> f64 {
        pairs.map(|(a, b)| a * b).sum()
    }
}

/// A 3-vector.
pub type Vec3<T> = [T; 3];
/// A 3 × 3 matrix, row-major.
pub type Mat3<T> = [[T; 3]; 3];

/// The 3 × 3 identity of `f64`.
pub const IDENTITY: Mat3<f64> = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// `A B` of 3 × 3 matrices.
pub fn mat3_mul<A: Arithmetic>(arithmetic: &mut A, a: &Mat3<A::Value>, b: &Mat3<A::Value>) -> Mat3<A::Value> {
    let mut entry = |i: usize, j: usize| arithmetic.dot((0..3).map(|k| (&a[i][k], &b[k][j])));
    [
        [entry(0, 0), entry(0, 1), entry(0, 2)],
        [entry(1, 0), entry(1, 1), entry(1, 2)],
        [entry(2, 0), entry(2, 1), entry(2, 2)],
    ]
}

/// `A v` of a 3 × 3 matrix and a 3-vector.
pub fn mat3_vec<A: Arithmetic>(arithmetic: &mut A, a: &Mat3<A::Value>, v: &Vec3<A::Value>) -> Vec3<A::Value> {
    let mut entry = |i: usize| arithmetic.dot(a[i].iter().zip(v.iter()));
    [entry(0), entry(1), entry(2)]
}

/// `a + b` of 3-vectors.
pub fn vec3_add<A: Arithmetic>(arithmetic: &mut A, a: &Vec3<A::Value>, b: &Vec3<A::Value>) -> Vec3<A::Value> {
    [arithmetic.add(&a[0], &b[0]), arithmetic.add(&a[1], &b[1]), arithmetic.add(&a[2], &b[2])]
}

/// `Aᵀ` of a 3 × 3 matrix.
pub fn transpose3<T: Clone>(a: &Mat3<T>) -> Mat3<T> {
    std::array::from_fn(|i| std::array::from_fn(|j| a[j][i].clone()))
}

/// A matrix of any size, row-major.
pub type Matrix<T> = Vec<Vec<T>>;

/// `A B` of matrices of any (compatible) size.
pub fn matrix_mul<A: Arithmetic>(
    arithmetic: &mut A,
    a: &[Vec<A::Value>],
    b: &[Vec<A::Value>],
) -> Matrix<A::Value> {
    let columns = b.first().map_or(0, Vec::len);
    a.iter()
        .map(|row| {
            (0..columns).map(|j| arithmetic.dot(row.iter().zip(b).map(|(x, b_row)| (x, &b_row[j])))).collect()
        })
        .collect()
}

/// `A v` of a matrix and a vector of any (compatible) size.
pub fn matrix_vec<A: Arithmetic>(arithmetic: &mut A, a: &[Vec<A::Value>], v: &[A::Value]) -> Vec<A::Value> {
    a.iter().map(|row| arithmetic.dot(row.iter().zip(v))).collect()
}

/// `A + B` of matrices of the same size.
pub fn matrix_add<A: Arithmetic>(
    arithmetic: &mut A,
    a: &[Vec<A::Value>],
    b: &[Vec<A::Value>],
) -> Matrix<A::Value> {
    a.iter().zip(b).map(|(x, y)| x.iter().zip(y).map(|(p, q)| arithmetic.add(p, q)).collect()).collect()
}

/// `Aᵀ` of a matrix of any size (an empty matrix stays empty).
pub fn matrix_transpose<T: Clone>(a: &[Vec<T>]) -> Matrix<T> {
    let columns = a.first().map_or(0, Vec::len);
    (0..columns).map(|j| a.iter().map(|row| row[j].clone()).collect()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn products_agree_with_a_hand_computed_example() {
        let a = [[1.0, 2.0, 0.0], [0.0, 1.0, 3.0], [4.0, 0.0, 1.0]];
        let b = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0]];
        assert_eq!(mat3_mul(&mut Numbers, &a, &b), [[2.0, 1.0, 0.0], [1.0, 0.0, 6.0], [0.0, 4.0, 2.0]]);
        assert_eq!(mat3_vec(&mut Numbers, &a, &[1.0, 1.0, 1.0]), [3.0, 4.0, 5.0]);
        assert_eq!(transpose3(&a)[0], [1.0, 0.0, 4.0]);
        let dynamic: Vec<Vec<f64>> = a.iter().map(|r| r.to_vec()).collect();
        let b_dynamic: Vec<Vec<f64>> = b.iter().map(|r| r.to_vec()).collect();
        let product = matrix_mul(&mut Numbers, &dynamic, &b_dynamic);
        assert_eq!(product[1], vec![1.0, 0.0, 6.0]);
        assert_eq!(matrix_transpose(&dynamic[..2])[2], vec![0.0, 3.0]);
        assert_eq!(matrix_add(&mut Numbers, &dynamic, &dynamic)[2], vec![8.0, 0.0, 2.0]);
        assert_eq!(matrix_vec(&mut Numbers, &dynamic, &[1.0, 0.0, 0.0]), vec![1.0, 0.0, 4.0]);
        assert_eq!(vec3_add(&mut Numbers, &[1.0, 2.0, 3.0], &[1.0, 1.0, 1.0]), [2.0, 3.0, 4.0]);
    }
}
