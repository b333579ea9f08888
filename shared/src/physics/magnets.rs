//! The rotor's magnets over one mechanical revolution (issue 69): how much of the
//! torque/back-EMF gain the two conducting phases keep at a rotor angle when one magnet is
//! weaker than the others.
//!
//! Units: mechanical radians from the encoder's zero, a magnet's flux as a share (0 … 1).
//! O(1) work per call (four angle reductions for [`WeakMagnet`], none for [`EvenMagnets`]),
//! no allocation.
//!
//! The monitor model's coil picture ([`crate::monitor`]): each phase has two full-pitch
//! coils side by side, `[group − π/P, group)` and `[group, group + π/P)`, and its coupling
//! is the mean of the two magnet edges under them (one edge under each coil at any angle).
//! An edge between two poles carries their mean flux, so each of the weak magnet's two edges
//! carries `1 − depth/2`: a phase keeps `1 − depth/4` of its coupling for each of them under
//! its coils. The pair's factor is the mean of its two phases'. A magnet's edges are sharp
//! here; the reference model's are ramps.

use crate::base::math::{floor, TAU};
use crate::physics::params::ActuatorParams;

/// What the rotor's magnets do to the conducting pair's gain at a rotor angle.
pub trait RotorMagnets: Copy {
    /// The share of its gain the pair keeps whose floating phase is `floating` (0, 1, 2 for
    /// A, B, C) at mechanical angle `theta_m` [rad]. O(1).
    fn pair_factor(&self, theta_m: f32, floating: usize) -> f32;
}

/// Every magnet alike: the gain the electrical shape functions give, unchanged (the factor
/// is the constant 1, which the compiler folds away).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct EvenMagnets;

impl RotorMagnets for EvenMagnets {
    #[inline(always)]
    fn pair_factor(&self, _theta_m: f32, _floating: usize) -> f32 {
        1.0
    }
}

/// One magnet that lost `depth` of its flux, centred `centre` [rad] mechanical ahead of the
/// encoder's zero, in the coil picture of the module's docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeakMagnet {
    /// Each weak edge's share of a phase's coupling lost: depth / 4.
    quarter_depth: f32,
    /// The weak magnet's two edges' offsets from the encoder's zero [rad].
    edges: [f32; 2],
    /// Each phase's coil span's start, `group − π/P` [rad].
    span_start: [f32; 3],
    /// The span's width, two pole pitches [rad].
    span: f32,
}

impl WeakMagnet {
    /// One magnet of the actuator `params` at `centre` [rad] that lost `depth` (clamped to
    /// 0 … 1) of its flux. O(1).
    pub fn new(params: &ActuatorParams, depth: f32, centre: f32) -> Self {
        let pole_pairs = if params.pole_pairs >= 1.0 {
            params.pole_pairs
        } else {
            1.0
        };
        let pitch = core::f32::consts::PI / pole_pairs;
        let depth = if depth > 0.0 { depth.min(1.0) } else { 0.0 };
        Self {
            quarter_depth: 0.25 * depth,
            edges: [centre - 0.5 * pitch, centre + 0.5 * pitch],
            span_start: params.winding_group_angle.map(|g| g - pitch),
            span: 2.0 * pitch,
        }
    }

    /// The share phase `phase` keeps at `theta_m`. O(1).
    fn phase_factor(&self, theta_m: f32, phase: usize) -> f32 {
        let start = self.span_start.get(phase).copied().unwrap_or(0.0);
        let mut under = 0.0;
        for edge in self.edges {
            let x = theta_m + edge - start;
            if x - TAU * floor(x / TAU) < self.span {
                under += 1.0;
            }
        }
        1.0 - self.quarter_depth * under
    }
}

impl RotorMagnets for WeakMagnet {
    #[inline]
    fn pair_factor(&self, theta_m: f32, floating: usize) -> f32 {
        let (y, z) = ((floating + 1) % 3, (floating + 2) % 3);
        0.5 * (self.phase_factor(theta_m, y) + self.phase_factor(theta_m, z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_weak_magnet_costs_each_phase_its_edges_under_its_coils() {
        let p = ActuatorParams::default();
        let pitch = core::f32::consts::PI / p.pole_pairs;
        let a = p.winding_group_angle[0];
        // Centred on phase A's coils' common side: both edges under them, A keeps 1 − d/2.
        let weak = WeakMagnet::new(&p, 0.4, 0.0);
        assert!((weak.phase_factor(a, 0) - 0.8).abs() < 1e-6);
        // A pitch on, one edge has left the span's far end and the other is still inside.
        assert!((weak.phase_factor(a + 1.0 * pitch, 0) - 0.9).abs() < 1e-6);
        // Far from A's span: nothing lost.
        assert!((weak.phase_factor(a + core::f32::consts::PI, 0) - 1.0).abs() < 1e-6);
        // A whole revolution later, the same.
        let once = weak.pair_factor(0.3, 1);
        let again = weak.pair_factor(0.3 + TAU, 1);
        assert!((once - again).abs() < 1e-5);
    }

    #[test]
    fn over_a_revolution_each_phase_loses_the_magnets_mean_share() {
        // Averaged over the rotor's angle each phase loses depth/(2P) of its coupling: the
        // flux the weak magnet took, shared over the 2P poles.
        let p = ActuatorParams::default();
        let weak = WeakMagnet::new(&p, 0.5, 1.1);
        let n = 20_000;
        for phase in 0..3 {
            let mean = (0..n)
                .map(|i| weak.phase_factor(TAU * i as f32 / n as f32, phase))
                .sum::<f32>()
                / n as f32;
            let lost = 0.5 / (2.0 * p.pole_pairs);
            assert!((1.0 - mean - lost).abs() < 1e-3, "phase {phase}: {mean}");
        }
    }

    #[test]
    fn even_magnets_keep_the_gain() {
        assert_eq!(EvenMagnets.pair_factor(1.234, 2), 1.0);
    }
}
