//! The rotor's magnets over one mechanical revolution (issue 69): how much of the
//! torque/back-EMF gain the two conducting phases keep at a rotor angle when one magnet is
//! weaker than the others.
//!
//! Units: mechanical radians from the encoder's zero, a magnet's flux as a share (0 … 1).
//! O(1) work per call (four angle reductions; none with even magnets), no allocation.
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

/// One magnet that lost `depth` of its flux, centred `centre` \[rad\] mechanical ahead of the
/// encoder's zero; [`WeakMagnet::NONE`]: every magnet alike.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WeakMagnet {
    /// Share of the magnet's flux lost (0 … 1).
    pub depth: f32,
    /// The magnet's centre \[rad\], mechanical, from the encoder's zero.
    pub centre: f32,
}

/// The pole pairs of `params`, at least 1.
pub fn pole_pairs(params: &ActuatorParams) -> f32 {
    if params.pole_pairs >= 1.0 {
        params.pole_pairs
    } else {
        1.0
    }
}

/// The poles of `params` (2P, at least 2).
pub fn poles(params: &ActuatorParams) -> u32 {
    let p = pole_pairs(params);
    // P ≥ 1 and finite here; an absurd P saturates.
    (2.0 * p + 0.5) as u32
}

/// One pole pitch of `params`, π/P \[rad\].
pub fn pole_pitch(params: &ActuatorParams) -> f32 {
    core::f32::consts::PI / pole_pairs(params)
}

impl WeakMagnet {
    /// Every magnet alike.
    pub const NONE: Self = Self {
        depth: 0.0,
        centre: 0.0,
    };

    /// `depth` clamped to 0 … 1 (NaN: none) at `centre` \[rad\]. O(1).
    pub fn new(depth: f32, centre: f32) -> Self {
        let depth = if depth > 0.0 { depth.min(1.0) } else { 0.0 };
        Self { depth, centre }
    }

    /// Whether every magnet is alike (no depth).
    pub fn is_none(&self) -> bool {
        self.depth == 0.0
    }

    /// The pole of `params` whose centre (`pole·π/P`) is nearest this magnet's (0 … 2P − 1).
    pub fn pole(&self, params: &ActuatorParams) -> u32 {
        let pitch = pole_pitch(params);
        let x = self.centre / pitch + 0.5;
        let turns = x - floor(x / 2.0 / pole_pairs(params)) * 2.0 * pole_pairs(params);
        (turns as u32) % poles(params)
    }

    /// The mean share of the flux the rotor keeps: `1 − depth/(2P)`.
    pub fn mean_kept(&self, params: &ActuatorParams) -> f32 {
        1.0 - self.depth / (2.0 * pole_pairs(params))
    }

    /// The share phase `phase` of `params` keeps at `theta_m` \[rad\]: `1 − depth/4` for
    /// each of the magnet's two edges under its coils. O(1): two angle reductions, unrolled
    /// (the monitor model calls it twice a step while it plays a weak magnet).
    #[inline(always)]
    fn phase_factor(&self, params: &ActuatorParams, pitch: f32, theta_m: f32, phase: usize) -> f32 {
        let group = params
            .winding_group_angle
            .get(phase)
            .copied()
            .unwrap_or(0.0);
        let start = group - pitch;
        let span = 2.0 * pitch;
        // An edge is under the phase's two coils when its angle from their start, reduced
        // to one revolution, is within two pitches.
        let under = |edge: f32| {
            let x = theta_m + edge - start;
            if x - TAU * floor(x / TAU) < span {
                1.0
            } else {
                0.0
            }
        };
        let under = under(self.centre - 0.5 * pitch) + under(self.centre + 0.5 * pitch);
        1.0 - 0.25 * self.depth * under
    }

    /// The share of its gain the conducting pair of `params` keeps whose floating phase is
    /// `floating` (0, 1, 2 for A, B, C; taken mod 3) at mechanical angle `theta_m` \[rad\].
    /// O(1): four angle reductions. Out of line: a model without a weak magnet never calls it.
    #[cold]
    #[inline(never)]
    pub fn pair_factor(&self, params: &ActuatorParams, theta_m: f32, floating: usize) -> f32 {
        let pitch = pole_pitch(params);
        let (y, z) = match floating % 3 {
            0 => (1, 2),
            1 => (2, 0),
            _ => (0, 1),
        };
        0.5 * (self.phase_factor(params, pitch, theta_m, y)
            + self.phase_factor(params, pitch, theta_m, z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_weak_magnet_costs_each_phase_its_edges_under_its_coils() {
        let p = ActuatorParams::default();
        let pitch = pole_pitch(&p);
        let a = p.winding_group_angle[0];
        // Centred on phase A's coils' common side: both edges under them, A keeps 1 − d/2.
        let weak = WeakMagnet::new(0.4, 0.0);
        assert!((weak.phase_factor(&p, pitch, a, 0) - 0.8).abs() < 1e-6);
        // A pitch on, one edge has left the span's far end and the other is still inside.
        assert!((weak.phase_factor(&p, pitch, a + pitch, 0) - 0.9).abs() < 1e-6);
        // Far from A's span: nothing lost.
        let far = a + core::f32::consts::PI;
        assert!((weak.phase_factor(&p, pitch, far, 0) - 1.0).abs() < 1e-6);
        // A whole revolution later, the same.
        let once = weak.pair_factor(&p, 0.3, 1);
        let again = weak.pair_factor(&p, 0.3 + TAU, 1);
        assert!((once - again).abs() < 1e-5);
    }

    #[test]
    fn over_a_revolution_each_phase_loses_the_magnets_mean_share() {
        // Averaged over the rotor's angle each phase loses depth/(2P) of its coupling: the
        // flux the weak magnet took, shared over the 2P poles.
        let p = ActuatorParams::default();
        let weak = WeakMagnet::new(0.5, 1.1);
        let pitch = pole_pitch(&p);
        let n = 20_000;
        for phase in 0..3 {
            let mean = (0..n)
                .map(|i| weak.phase_factor(&p, pitch, TAU * i as f32 / n as f32, phase))
                .sum::<f32>()
                / n as f32;
            assert!(
                (mean - weak.mean_kept(&p)).abs() < 1e-3,
                "phase {phase}: {mean}"
            );
        }
    }

    #[test]
    fn the_pole_is_the_nearest_centre_round_the_rotor() {
        let p = ActuatorParams::default();
        let pitch = pole_pitch(&p);
        assert_eq!(poles(&p), 8);
        assert_eq!(WeakMagnet::new(0.5, 3.0 * pitch).pole(&p), 3);
        assert_eq!(WeakMagnet::new(0.5, 3.4 * pitch).pole(&p), 3);
        assert_eq!(WeakMagnet::new(0.5, 7.6 * pitch).pole(&p), 0);
        assert_eq!(WeakMagnet::new(0.5, -0.6 * pitch).pole(&p), 7);
        assert_eq!(WeakMagnet::new(0.5, 2.0 * TAU + pitch).pole(&p), 1);
    }

    #[test]
    fn depth_is_a_share_and_none_is_none() {
        assert!(WeakMagnet::NONE.is_none());
        assert!(WeakMagnet::new(-0.2, 1.0).is_none());
        assert!(WeakMagnet::new(f32::NAN, 1.0).is_none());
        assert_eq!(WeakMagnet::new(1.7, 1.0).depth, 1.0);
    }
}
