//! Identification error metrics, paper eq. (4).
//!
//! `e_i = |k_i,identified − k_i,true|` in percent of the `[0, 1]` range, `e_7` on the circle;
//! `e_tot = √((Σ_{i≠7} e_i² + k6_true · e_7²) / 8)` [%], over the paper's eight components
//! for every comparison with its tables; [`total_error_all`] is the same mean over all nine,
//! [`total_error_with_magnets`] over the nine and the weak magnet's depth.
//! O(9).

use crate::base::math::sqrt;
use crate::physics::fault::{FaultVector, CIRCULAR, FAULT_COUNT, PAPER_FAULT_COUNT};
use crate::physics::magnets::WeakMagnet;

/// Per-component errors `e_i` [%].
pub fn component_errors(identified: &FaultVector, truth: &FaultVector) -> [f32; FAULT_COUNT] {
    let (a, b) = (identified.as_array(), truth.as_array());
    core::array::from_fn(|i| {
        let (Some(&x), Some(&y), Some(&circular)) = (a.get(i), b.get(i), CIRCULAR.get(i)) else {
            return 0.0;
        };
        let d = if x > y { x - y } else { y - x };
        let d = if circular && d > 0.5 { 1.0 - d } else { d };
        100.0 * d
    })
}

/// Total identification error `e_tot` [%], eq. (4), over the paper's eight components: `e_7`
/// weighted by the true eccentricity.
pub fn total_error(identified: &FaultVector, truth: &FaultVector) -> f32 {
    mean_error(identified, truth, PAPER_FAULT_COUNT)
}

/// Eq. (4)'s root mean square over all [`FAULT_COUNT`] components, demagnetization included.
pub fn total_error_all(identified: &FaultVector, truth: &FaultVector) -> f32 {
    mean_error(identified, truth, FAULT_COUNT)
}

/// Eq. (4)'s root mean square over all [`FAULT_COUNT`] components and the weak magnet's depth
/// (`read` against `played`; its centre is scored apart, as a pole right or wrong).
pub fn total_error_with_magnets(
    identified: &FaultVector,
    read: &WeakMagnet,
    truth: &FaultVector,
    played: &WeakMagnet,
) -> f32 {
    let all = mean_error(identified, truth, FAULT_COUNT);
    let depth = 100.0 * (read.depth - played.depth);
    sqrt((all * all * FAULT_COUNT as f32 + depth * depth) / (FAULT_COUNT + 1) as f32)
}

fn mean_error(identified: &FaultVector, truth: &FaultVector, count: usize) -> f32 {
    let e = component_errors(identified, truth);
    let weight_phase = truth.eccentricity();
    let sum: f32 = e
        .iter()
        .zip(CIRCULAR)
        .take(count)
        .map(|(&ei, circular)| {
            if circular {
                weight_phase * ei * ei
            } else {
                ei * ei
            }
        })
        .sum();
    sqrt(sum / count as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn k(v: [f32; 8]) -> FaultVector {
        FaultVector::from_paper(v).unwrap()
    }

    #[test]
    fn the_weak_magnets_depth_is_a_tenth_term() {
        let t = FaultVector::NOMINAL;
        let none = WeakMagnet::NONE;
        let half = WeakMagnet::new(0.5, 1.0);
        assert_eq!(total_error_with_magnets(&t, &none, &t, &none), 0.0);
        let e = total_error_with_magnets(&t, &none, &t, &half);
        assert!((e - 50.0 / 10f32.sqrt()).abs() < 1e-3, "{e}");
        let i = k([0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
        let e = total_error_with_magnets(&i, &half, &t, &half);
        assert!((e - 10.0 / 10f32.sqrt()).abs() < 1e-3, "{e}");
    }

    #[test]
    fn zero_for_exact_match() {
        let t = k([0.1, 0.2, 0.3, 0.0, 0.0, 0.4, 0.9, 0.5]);
        assert_eq!(total_error(&t, &t), 0.0);
    }

    #[test]
    fn single_component_error() {
        let t = FaultVector::NOMINAL;
        let i = k([0.08, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
        let e = component_errors(&i, &t);
        assert!((e[0] - 8.0).abs() < 1e-4);
        assert!((total_error(&i, &t) - 8.0 / 8f32.sqrt()).abs() < 1e-4);
    }

    #[test]
    fn phase_error_wraps_and_is_weighted_by_true_eccentricity() {
        let t = k([0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.98, 0.5]);
        let i = k([0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.02, 0.5]);
        let e = component_errors(&i, &t);
        assert!((e[6] - 4.0).abs() < 1e-3, "{}", e[6]);
        assert!((total_error(&i, &t) - (0.5f32 * 16.0 / 8.0).sqrt()).abs() < 1e-3);
        // With no eccentricity its phase does not count.
        let t0 = k([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.98, 0.5]);
        let i0 = k([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3, 0.5]);
        assert_eq!(total_error(&i0, &t0), 0.0);
    }

    #[test]
    fn the_papers_error_leaves_demagnetization_out_and_the_nine_component_one_counts_it() {
        let t = FaultVector::NOMINAL;
        let mut v = *t.as_array();
        v[8] = 0.09;
        let i = FaultVector::new(v).unwrap();
        assert_eq!(total_error(&i, &t), 0.0);
        assert!((total_error_all(&i, &t) - 9.0 / 3.0).abs() < 1e-4);
    }
}
