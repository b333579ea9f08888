//! What the emulator fed the image, frame by frame, as a trace the host and the emulation
//! image read: each trigger's conversions and encoder capture ([`Counts`]), converted by the
//! board's own `Converter` (the image's arithmetic, on the host), with the test's command —
//! or, for a window of flight, the command the board's flight followed (`FlightCommand` on
//! the demand it read). O(frames).

use anyhow::{Context, Result};
use firmware::acquisition::{Converter, Counts, SensorScaling};
use firmware::flight::FlightCommand;
use firmware::sequencer::Drive as SequencedDrive;
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
        let command = match record.test.drive(k, record.params.control_period) {
            Drive::Position(x) => f64::from(x),
            Drive::Pair(_) => 0.0,
        };
        trace.push(sample(&mut converter, c, k, command));
    }
    Ok(trace)
}

/// The window of flight the image measured from frame `first` on (the count since power-up
/// its log gives), `frames` frames of `record`'s chirp alone, with the command its flight
/// followed: the demand read at each frame, low-passed, the chirp superimposed a period
/// ahead, replayed by the image's own `FlightCommand` from the flight's first frame. The encoder's count
/// is continued from power-up, as the image's.
pub fn window_trace(
    counts: &[Counts],
    record: &ActuatorRecord,
    first: usize,
    frames: usize,
) -> Result<Trace> {
    let end = first + frames;
    anyhow::ensure!(
        first > 0 && counts.len() >= end,
        "{} frames fed, a window of {frames} from {first} asked",
        counts.len()
    );
    let scaling = SensorScaling::REFERENCE_BOARD;
    let mut converter = Converter::new(scaling);
    for c in &counts[..first] {
        converter.convert(c);
    }
    let demand = |c: &Counts| {
        scaling
            .demand(c.demand)
            .context("a window's frame without the flight's demand")
    };
    // The flight's command from its first frame (the first with a demand before the
    // window): its demand filter's state is the flight's.
    let flown = counts[..first]
        .iter()
        .rev()
        .take_while(|c| scaling.demand(c.demand).is_some())
        .count();
    anyhow::ensure!(flown > 0, "no flight before the window at frame {first}");
    let mut command = FlightCommand::follow(record.params.control_period);
    for c in &counts[first - flown..first] {
        command.tick(demand(c)?, &mut Nothing);
    }
    let test = record.test.chirp_only();
    command.begin_window(test, record.params.control_period);
    let mut trace = Trace::with_capacity(frames).with_test(test).as_flight();
    for (k, c) in counts[first..end].iter().enumerate() {
        // As the image keeps it: on the trace's grid, so a trace in memory reads as its file.
        let acting = shared::trace::command_as_traced(command.tick(demand(c)?, &mut Nothing));
        trace.push(sample(&mut converter, c, k, f64::from(acting)));
    }
    Ok(trace)
}

/// A drive that drives nothing: the command alone is wanted.
struct Nothing;

impl SequencedDrive for Nothing {
    fn position(&mut self, _: f32) {}
    fn pair_voltage(&mut self, _: u8, _: f32) {}
    fn off(&mut self, _: u8) {}
    fn lead(&self) -> usize {
        1
    }
}

/// Frame `k` of a trace: `c` converted as the image converts it, with `command` [rad].
fn sample(converter: &mut Converter, c: &Counts, k: usize, command: f64) -> TraceSample {
    // The frame the image pushed, in its fixed point, back to f64 exactly: the trace's rows
    // hold the same fixed-point values.
    let (frame, _) = converter.convert(c);
    let conditions = frame.conditions.unwrap_or_default();
    TraceSample {
        time: k as f64 / f64::from(SAMPLE_RATE_HZ),
        command,
        phase_currents: frame.phase_currents.map(|x| x.to_num::<f64>()),
        motor_angle: frame.motor_angle.to_num::<f64>(),
        user_angle: frame.user_angle.to_num::<f64>(),
        bus_voltage: Some(conditions.bus_voltage.to_num::<f64>()),
        temperature: Some(conditions.temperature.to_num::<f64>()),
    }
}

/// The windows a decoded log reports: `(n, first_frame, frames)` of each
/// `window n=… first_frame=… frames=…` line.
pub fn windows_in_log(log: &str) -> Vec<(u32, usize, usize)> {
    let field = |line: &str, key: &str| -> Option<usize> {
        let at = line.find(key)? + key.len();
        line[at..].split(' ').next()?.parse().ok()
    };
    log.lines()
        .filter_map(|l| {
            let l = &l[l.find("window n=")?..];
            Some((
                u32::try_from(field(l, "n=")?).ok()?,
                field(l, "first_frame=")?,
                field(l, "frames=")?,
            ))
        })
        .collect()
}
