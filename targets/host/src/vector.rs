//! The small vector operations the host's geometry shares, once for the crate: the contact
//! checks' forces and normals, the scene objects' own inside tests (a mesh's ray parity and
//! closest points), a replay's polytope edges. Task vectors have 1 to 3 coordinates and come
//! as slices; the mesh code works on `[f64; 3]`, which the slice functions take as they are.
//!
//! Each sum runs over the coordinates in order, as the code these replaced did, so that every
//! number the host computes with them is the same to the last bit.

/// The dot product `a · b` (over the shorter of the two).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The length `|a|`.
pub fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// The distance `|a − b|` (over the shorter of the two).
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt()
}

/// The difference `a − b`.
pub fn sub<const N: usize>(a: &[f64; N], b: &[f64; N]) -> [f64; N] {
    std::array::from_fn(|k| a[k] - b[k])
}

/// The cross product `a × b` (right-handed).
pub fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[cfg(test)]
mod tests {
    use super::{cross, distance, dot, norm, sub};

    #[test]
    fn products_length_and_distance() {
        let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        assert_eq!(cross(&x, &y), z);
        assert_eq!(cross(&y, &z), x);
        assert_eq!(dot(&x, &y), 0.0);
        assert_eq!(dot(&[1.0, 2.0], &[3.0, 4.0]), 11.0);
        assert_eq!(norm(&[2.0, 3.0, 6.0]), 7.0);
        assert_eq!(sub(&[3.0, 5.0, -1.0], &[1.0, 1.0, 1.0]), [2.0, 4.0, -2.0]);
        assert_eq!(distance(&[1.0, 1.0], &[4.0, 5.0]), 5.0);
    }

    /// The sums start from −0, not +0 (Rust's `Sum` for floats): a product of one negative
    /// zero stays one, as in the written-out `a₀b₀ + a₁b₁ + a₂b₂` these functions replaced.
    #[test]
    fn a_dot_product_keeps_the_sign_of_zero() {
        assert!(dot(&[-0.0], &[1.0]).is_sign_negative());
    }
}
