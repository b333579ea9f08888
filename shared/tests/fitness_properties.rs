//! Property tests: any fault vector in [0, 1]^9 against any finite trace the controller can
//! hold gives a finite fitness, with and without a bound, and the conditioning and the
//! monitor model never panic on the way. "Any trace" covers the whole fixed-point range of
//! every ADC word (raw bits), ordinary currents and angles, and flat or spiky stretches.

use fixed::types::{I16F16, I4F28};
use proptest::prelude::*;
use shared::conditioning::{AdcFrame, MeasuredCurrent};
use shared::fdi::OnboardMeasured;
use shared::{ActuatorParams, Calibration, FaultVector, FitnessProblem, LowPass};

/// The shortest trace the fitness accepts: keeps each case fast.
const SHORT: usize = OnboardMeasured::MIN_SAMPLES;

/// One ADC frame: either raw bits over the whole range or values of an ordinary test.
fn frame() -> impl Strategy<Value = AdcFrame> {
    let raw = (any::<[i32; 3]>(), any::<i32>(), any::<i32>()).prop_map(|(c, m, u)| AdcFrame {
        phase_currents: c.map(I16F16::from_bits),
        motor_angle: I16F16::from_bits(m),
        user_angle: I4F28::from_bits(u),
        conditions: None,
    });
    let ordinary = (
        prop::array::uniform3(-20.0f32..20.0),
        -30.0f32..30.0,
        -0.5f32..0.5,
    )
        .prop_map(|(c, m, u)| AdcFrame::from_f32(c, m, u));
    prop_oneof![ordinary, raw]
}

/// A trace of `SHORT` frames built from up to 12 segments, each one frame held for a while
/// (flat stretches, steps and full-scale spikes all appear).
fn trace() -> impl Strategy<Value = Vec<AdcFrame>> {
    prop::collection::vec((frame(), 1usize..400), 1..12).prop_map(|segments| {
        segments
            .iter()
            .flat_map(|(f, n)| std::iter::repeat_n(*f, *n))
            .cycle()
            .take(SHORT)
            .collect()
    })
}

fn fault_vector() -> impl Strategy<Value = [f32; 9]> {
    prop::array::uniform9(0.0f32..=1.0)
}

fn conditioned(frames: &[AdcFrame]) -> Box<MeasuredCurrent<SHORT>> {
    let filter = LowPass::for_control_period(1.0e-4).unwrap();
    let mut m = Box::new(MeasuredCurrent::<SHORT>::new(filter));
    for f in frames {
        m.push_frame(*f, ActuatorParams::REFERENCE.pole_pairs)
            .unwrap();
    }
    m
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn any_fault_vector_and_any_finite_trace_give_a_finite_fitness(
        frames in trace(),
        k in fault_vector(),
        bound in prop_oneof![Just(f32::INFINITY), 0.0f32..10.0],
    ) {
        let mut m = conditioned(&frames);
        // Every frame holds finite fixed-point numbers, so conditioning always succeeds.
        prop_assert_eq!(m.finish(), Ok(()));
        let k = FaultVector::new(k).unwrap();
        for calibration in [Calibration::REFERENCE_ACTUATOR_STEPS, Calibration::IDENTITY] {
            let problem = FitnessProblem::new(&m, ActuatorParams::REFERENCE, &calibration)
                .unwrap();
            let f = problem.error(&k);
            prop_assert!(f.is_finite(), "error {} for {:?}", f, k.as_array());
            let raw = problem.raw_error(&k);
            prop_assert!(raw.is_finite() && raw >= 0.0, "raw error {}", raw);
            let below = problem.error_below(&k, bound);
            prop_assert!(below.is_finite(), "bounded error {}", below);
            if f < bound {
                prop_assert_eq!(below.to_bits(), f.to_bits());
            }
        }
    }

    #[test]
    fn the_corners_of_the_fault_space_give_a_finite_fitness(
        frames in trace(),
        corner in any::<u16>(),
    ) {
        let mut m = conditioned(&frames);
        prop_assert_eq!(m.finish(), Ok(()));
        let k = core::array::from_fn(|i| if corner & (1 << i) != 0 { 1.0 } else { 0.0 });
        let k = FaultVector::new(k).unwrap();
        let problem = FitnessProblem::new(
            &m,
            ActuatorParams::REFERENCE,
            &Calibration::REFERENCE_ACTUATOR_STEPS,
        )
        .unwrap();
        let f = problem.error(&k);
        prop_assert!(f.is_finite(), "error {} for {:?}", f, k.as_array());
    }
}
