//! Regular grids over a box of coordinates: `steps` evenly spaced values per axis from its
//! lower to its upper bound, bounds included, every combination once. The one grid behind the
//! analyses that sample a rig's joint box (plausibility, wall stability) and the design
//! report's workspace maps; the first axis varies fastest.

/// The points of the grid with `steps` values per axis over `bounds` (`(lower, upper)` per
/// axis): `steps^n` points, the first axis varying fastest. One value per axis is the box's
/// middle; none when `steps` is 0 or `steps^n` does not fit a `usize`.
pub fn box_grid(bounds: &[(f64, f64)], steps: usize) -> impl Iterator<Item = Vec<f64>> + '_ {
    let count = steps.checked_pow(bounds.len() as u32).unwrap_or(0);
    (0..count).map(move |mut index| {
        bounds
            .iter()
            .map(|&(lower, upper)| {
                let i = index % steps;
                index /= steps;
                if steps == 1 {
                    0.5 * (lower + upper)
                } else {
                    lower + (upper - lower) * i as f64 / (steps - 1) as f64
                }
            })
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::box_grid;

    #[test]
    fn the_grid_holds_every_combination_with_the_bounds_and_the_first_axis_fastest() {
        let points: Vec<Vec<f64>> = box_grid(&[(0.0, 1.0), (-2.0, 2.0)], 3).collect();
        assert_eq!(points.len(), 9);
        assert_eq!(points[0], [0.0, -2.0]);
        assert_eq!(points[1], [0.5, -2.0]);
        assert_eq!(points[3], [0.0, 0.0]);
        assert_eq!(points[8], [1.0, 2.0]);
        let mut sorted = points.clone();
        sorted.sort_by(|a, b| a.partial_cmp(b).unwrap());
        sorted.dedup();
        assert_eq!(sorted.len(), 9, "each point once");
    }

    #[test]
    fn one_step_is_the_middle_and_no_steps_or_an_overflow_is_empty() {
        assert_eq!(box_grid(&[(1.0, 3.0)], 1).collect::<Vec<_>>(), [[2.0]]);
        assert_eq!(box_grid(&[(1.0, 3.0)], 0).count(), 0);
        assert_eq!(box_grid(&[(0.0, 1.0); 80], 3).count(), 0);
    }
}
