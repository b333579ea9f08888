//! What the noise examples (`noise_source`, `noise_bias`) share: their cases and the
//! equivalent current of a trace sample. Not an example of its own.

use shared::conditioning::commutation_signs;

/// The cases: (name, fault vector).
pub const CASES: [(&str, [f32; 9]); 4] = [
    ("healthy", [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]),
    (
        "friction 0.2",
        [0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ),
    // The same friction with the eccentricity away from its bound at 0.
    (
        "friction 0.2, eccentricity 0.2",
        [0.2, 0.0, 0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.0],
    ),
    (
        "Table II medium",
        [0.4, 0.4, 0.2, 0.1, 0.05, 0.2, 0.75, 0.6, 0.0],
    ),
];

/// The equivalent current of one sample as the conditioning forms it (½·Σ s_x·i_x) \[A\].
pub fn equivalent(s: &host_sim::files::trace::TraceSample, pole_pairs: f32) -> f64 {
    let signs = commutation_signs(s.motor_angle as f32 * pole_pairs);
    0.5 * s
        .phase_currents
        .iter()
        .zip(signs)
        .map(|(i, sign)| f64::from(sign) * i)
        .sum::<f64>()
}
