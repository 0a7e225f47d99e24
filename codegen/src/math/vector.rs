//! Small operations on 3-vectors of numbers, once for the generator's numerical analyses (the
//! closed chains' sphere intersection, compound joints' axes, mesh normals, the plausibility
//! checks' extents): `a · b`, `a × b`, `a − b`, `k a` and `|a|`.

/// The dot product `a · b`.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The cross product `a × b` (right-handed).
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// The difference `a − b`.
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The multiple `k a`.
pub fn scaled(k: f64, a: [f64; 3]) -> [f64; 3] {
    a.map(|x| k * x)
}

/// The length `|a|`.
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::{cross, dot, norm, scaled, sub};

    #[test]
    fn difference_multiple_and_length() {
        assert_eq!(sub([3.0, 5.0, -1.0], [1.0, 1.0, 1.0]), [2.0, 4.0, -2.0]);
        assert_eq!(scaled(-0.5, [2.0, 4.0, -2.0]), [-1.0, -2.0, 1.0]);
        assert_eq!(norm([2.0, 3.0, 6.0]), 7.0);
    }

    #[test]
    fn the_products_of_the_unit_axes() {
        let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        assert_eq!(cross(x, y), z);
        assert_eq!(cross(y, z), x);
        assert_eq!(cross(z, x), y);
        assert_eq!(dot(x, y), 0.0);
        // a × b is perpendicular to both, and |a × b|² + (a · b)² = |a|² |b|² (Lagrange).
        let (a, b) = ([1.5, -2.0, 0.25], [0.5, 3.0, -1.0]);
        let c = cross(a, b);
        assert!(dot(c, a).abs() < 1e-12 && dot(c, b).abs() < 1e-12);
        assert!((dot(c, c) + dot(a, b).powi(2) - dot(a, a) * dot(b, b)).abs() < 1e-12);
    }
}
