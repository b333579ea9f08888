//! What the emulator fed the image, frame by frame, as a trace the host and the emulation
//! image read: each trigger's conversions and encoder capture ([`Counts`]), converted by the
//! board's own `Converter` (the image's arithmetic, on the host), with the test's command.
//! O(frames).

use anyhow::Result;
use firmware::acquisition::{Converter, Counts, SensorScaling};
use host_sim::files::trace::{Trace, TraceSample, SAMPLE_RATE_HZ};
use shared::actuator::ActuatorRecord;
use shared::test_design::Drive;

/// The trace of the first `frames` triggers' counts, declared as `record`'s test: what the
/// image measured, as the host's `identify` and the emulation image read it.
pub fn fed_trace(counts: &[Counts], record: &ActuatorRecord, frames: usize) -> Result<Trace> {
    anyhow::ensure!(
        counts.len() >= frames,
        "{} frames fed, {frames} asked",
        counts.len()
    );
    let mut converter = Converter::new(SensorScaling::REFERENCE_BOARD);
    let mut trace = Trace::with_capacity(frames).with_test(record.test);
    for (k, c) in counts.iter().take(frames).enumerate() {
        // The frame the image pushed, in its fixed point, back to f64 exactly: the trace's
        // rows hold the same fixed-point values.
        let (frame, _) = converter.convert(c);
        let conditions = frame.conditions.unwrap_or_default();
        let command = match record.test.drive(k, record.params.control_period) {
            Drive::Position(x) => f64::from(x),
            Drive::Pair(_) => 0.0,
        };
        trace.push(TraceSample {
            time: k as f64 / f64::from(SAMPLE_RATE_HZ),
            command,
            phase_currents: frame.phase_currents.map(|x| x.to_num::<f64>()),
            motor_angle: frame.motor_angle.to_num::<f64>(),
            user_angle: frame.user_angle.to_num::<f64>(),
            bus_voltage: Some(conditions.bus_voltage.to_num::<f64>()),
            temperature: Some(conditions.temperature.to_num::<f64>()),
        });
    }
    Ok(trace)
}
