//! The firmware ELF under QEMU (netduinoplus2, STM32F405) against the host: a faulty actuator
//! simulated by the reference model, its binary trace identified by the firmware through
//! `firmware/qemu-run` (semihosting + defmt-print) and by `host-sim identify`'s code, same
//! seed and calibration: the fault vector and fitness must be the same bits. Also checks the
//! heartbeat task kept running during identification, and that bad input, a panic and a
//! HardFault end the run with a message and a non-zero exit status.
//!
//! Needs `qemu-system-arm`, `defmt-print` and the `thumbv7em-none-eabihf` target (`.ci/run`
//! installs them). The firmware is built with `cargo fw-build`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use host_sim::fdi::identify::identify;
use host_sim::files::trace::Trace;
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
use shared::fdi::TEST_SAMPLES;
use shared::test_design::PreflightTest;
use shared::{ActuatorParams, Calibration, FaultVector, FAULT_COUNT};

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ sits in the workspace root")
        .to_path_buf()
}

/// Builds the firmware once per test binary; returns the ELF's path.
fn firmware_elf() -> &'static Path {
    static ELF: OnceLock<PathBuf> = OnceLock::new();
    ELF.get_or_init(|| {
        let out = Command::new(env!("CARGO"))
            .args(["fw-build", "--message-format=json"])
            .current_dir(workspace_root())
            .output()
            .expect("cargo runs");
        assert!(
            out.status.success(),
            "cargo fw-build failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        let exe = stdout
            .lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|m| m["reason"] == "compiler-artifact" && m["target"]["name"] == "firmware")
            .find_map(|m| m["executable"].as_str().map(PathBuf::from))
            .expect("cargo fw-build reports the firmware executable");
        assert!(exe.exists(), "{} missing", exe.display());
        exe
    })
}

struct Run {
    status: i32,
    output: String,
}

/// Runs the firmware under QEMU with `args` on its semihosting command line.
fn run_firmware(args: &[&str]) -> Run {
    let out = Command::new(workspace_root().join("firmware/qemu-run"))
        .arg(firmware_elf())
        .args(args)
        .output()
        .expect("firmware/qemu-run starts");
    let mut output = String::from_utf8_lossy(&out.stdout).into_owned();
    output += &String::from_utf8_lossy(&out.stderr);
    Run {
        status: out.status.code().unwrap_or(-1),
        output,
    }
}

/// The value of `key=` in the output line starting with `prefix`.
fn field<'a>(output: &'a str, prefix: &str, key: &str) -> &'a str {
    let line = output
        .lines()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line starting with {prefix:?} in:\n{output}"));
    let start = line
        .find(&format!("{key}="))
        .unwrap_or_else(|| panic!("no {key}= in {line:?}"))
        + key.len()
        + 1;
    let rest = &line[start..];
    let end = if rest.starts_with('[') {
        rest.find(']').expect("closing bracket") + 1
    } else {
        rest.find(' ').unwrap_or(rest.len())
    };
    &rest[..end]
}

fn number(output: &str, prefix: &str, key: &str) -> u64 {
    let text = field(output, prefix, key);
    text.parse()
        .unwrap_or_else(|_| panic!("{prefix} {key}={text:?} is not a number"))
}

fn list(text: &str) -> Vec<&str> {
    text.trim_start_matches('[')
        .trim_end_matches(']')
        .split(", ")
        .collect()
}

fn temp_trace(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ema-fdi-firmware-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
    std::fs::write(&path, bytes).expect("trace written");
    path
}

/// The host's answer for a binary trace: the trace as `host-sim identify` reads it, same
/// seed (1) and the built-in calibration. Returns the conditioned buffer too.
fn host_identification(
    bytes: &[u8],
) -> (
    Box<shared::fdi::OnboardMeasured>,
    shared::fdi::IdentificationResult,
) {
    let (measured, identified) = host_identified(bytes);
    (measured, identified.result)
}

/// The host's whole identification of `bytes`: its reading and the uncertainty it reports.
fn host_identified(
    bytes: &[u8],
) -> (
    Box<shared::fdi::OnboardMeasured>,
    host_sim::fdi::identify::Identified,
) {
    let measured = Trace::from_bin(bytes)
        .expect("readable")
        .measured(&ActuatorParams::REFERENCE)
        .expect("conditioned");
    let identified = identify(&measured, &Calibration::REFERENCE_ACTUATOR, 1, false)
        .expect("host identification runs");
    (measured, identified)
}

fn faulty_trace() -> Trace {
    let faults = FaultVector::new([0.2, 0.3, 0.15, 0.0, 0.0, 0.0, 0.5, 0.45, 0.0]).expect("valid");
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let mut scenario = Scenario::new(faults);
    scenario.seed = 3;
    rm.simulate(&scenario).trace
}

#[test]
fn firmware_under_qemu_gives_the_hosts_bits() {
    let trace = faulty_trace();
    let bytes = trace.to_bin().expect("encodable");
    let path = temp_trace("faulty.bin", &bytes);

    // A health log of 12 earlier flights on the path to this actuator's faults.
    let log_path = temp_trace("health.bin", &[]);
    std::fs::remove_file(&log_path).expect("fresh log");
    let earlier = earlier_flights(&log_path);

    let run = run_firmware(&[
        path.to_str().expect("UTF-8 temp path"),
        "--health",
        log_path.to_str().expect("UTF-8 temp path"),
    ]);
    assert_eq!(run.status, 0, "firmware failed:\n{}", run.output);
    println!("{}", run.output);

    let (_, identified) = host_identified(&bytes);
    let host = identified.result;

    let bits = list(field(&run.output, "bits ", "faults"));
    assert_eq!(bits.len(), FAULT_COUNT);
    for (i, (fw, h)) in bits.iter().zip(host.faults.as_array()).enumerate() {
        let fw = u32::from_str_radix(fw, 16).expect("hex bits");
        assert_eq!(
            fw,
            h.to_bits(),
            "k{} differs: firmware {} host {h}",
            i + 1,
            f32::from_bits(fw)
        );
    }
    let fitness = u32::from_str_radix(field(&run.output, "bits ", "fitness"), 16).expect("hex");
    assert_eq!(fitness, host.fitness.to_bits(), "fitness differs");
    // The uncertainty the host reports (at the solver's vector, the reading's eccentricity
    // corrected for its free phase): the same standard deviations and 90 % intervals, bit
    // for bit.
    let (u, _) = identified.uncertainty.expect("determined");
    // The readable line's decimals are the shortest that read back to the same `f32` (as the
    // `result` line's below), so they carry the bits; a NaN (an undetermined component) is
    // printed without its payload.
    for (key, host_values) in [("std", u.std), ("lower", u.lower), ("upper", u.upper)] {
        let fw: Vec<f32> = list(field(&run.output, "uncertainty ", key))
            .iter()
            .map(|x| x.parse().expect("a float"))
            .collect();
        assert_eq!(fw.len(), FAULT_COUNT, "uncertainty {key}");
        for (i, (f, h)) in fw.iter().zip(host_values).enumerate() {
            assert!(
                f.to_bits() == h.to_bits() || (f.is_nan() && h.is_nan()),
                "uncertainty {key} k{} differs: firmware {f} host {h}",
                i + 1
            );
        }
    }
    assert!(u.std[0].is_finite() && u.std[0] > 0.0, "{u:?}");
    health_matches_the_host(
        &run.output,
        &log_path,
        earlier,
        &host,
        &u,
        &identified.conditions,
    );
    // The readable line says the same numbers.
    let shown: Vec<f32> = list(field(&run.output, "result ", "faults"))
        .iter()
        .map(|x| x.parse().expect("a float"))
        .collect();
    assert_eq!(shown.as_slice(), host.faults.as_array().as_slice());
    assert_eq!(
        number(&run.output, "result ", "evaluations"),
        u64::from(host.evaluations)
    );
    assert_eq!(
        run.output
            .lines()
            .filter(|l| l.starts_with("verdict "))
            .count(),
        FAULT_COUNT
    );

    // The heartbeat ran between every two identification ticks, and a tick did at most the
    // configured number of evaluations.
    let polls = number(&run.output, "heartbeat ", "identify_polls");
    let per_tick = u64::from(firmware::PreflightSettings::ONBOARD.evaluations_per_poll);
    // The GA's evaluations ran in Identify's ticks; the polish's and the weak-magnet
    // search's (with its own polishes) in their own stages.
    let (after_ga, _) = shared::weak_magnet::WeakMagnetSearch::work_after_ga(
        &ActuatorParams::default(),
        &shared::polish::PolishSettings::FDI,
    );
    assert!(polls * per_tick + u64::from(after_ga) >= u64::from(host.evaluations));
    assert_eq!(
        number(&run.output, "heartbeat ", "polls_without_beat"),
        0,
        "{}",
        run.output
    );
    assert!(number(&run.output, "heartbeat ", "beats_during_identify") >= polls);
    assert_eq!(
        number(&run.output, "ticks ", "max_evaluations_per_tick"),
        per_tick
    );
    // Every frame of the default test (the injection, then the chirp).
    let frames = PreflightTest::INJECTION.samples(1.0e-4) as u64;
    assert!(frames <= TEST_SAMPLES as u64);
    assert_eq!(number(&run.output, "ticks ", "frames"), frames);
    // The stack was painted and scanned: something was used, not everything.
    let stack = number(&run.output, "footprint ", "stack_peak");
    assert!(stack > 0 && stack < number(&run.output, "footprint ", "stack_size"));
}

/// One magnet at half its flux (pole 3 of the reference actuator's eight) on an otherwise
/// healthy actuator: the firmware's weak-magnet search must read it at its pole, with no
/// eccentricity standing in for it, and with the host's bits for the vector, the magnet and
/// its depth's deviation; its verdict `FAULT`, its 90 % interval holding the truth.
#[test]
fn a_weak_magnet_under_qemu_is_read_at_its_pole_with_the_hosts_bits() {
    use host_sim::plant::reference::Demagnetization;
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE)
        .with_demagnetization(Demagnetization::Partial { loss: 0.5, pole: 3 });
    let mut scenario = Scenario::new(FaultVector::NOMINAL);
    scenario.seed = 4;
    let bytes = rm.simulate(&scenario).trace.to_bin().expect("encodable");
    let path = temp_trace("weak-magnet.bin", &bytes);
    // Twelve earlier preflights: four that read no weak magnet, then the magnet at pole 3
    // growing from 0.1 to 0.45 of its flux.
    let earlier = weak_magnet_log();
    let log_path = temp_trace("weak-magnet-health.bin", &earlier);
    let run = run_firmware(&[
        path.to_str().expect("UTF-8 temp path"),
        "--health",
        log_path.to_str().expect("UTF-8 temp path"),
    ]);
    assert_eq!(run.status, 0, "firmware failed:\n{}", run.output);

    let (_, identified) = host_identified(&bytes);
    let host = identified.result;
    assert_eq!(result_bits(&run.output), host_bits(&host), "{}", run.output);
    let bits: Vec<u32> = field(&run.output, "magnets ", "bits")
        .split(',')
        .map(|x| u32::from_str_radix(x, 16).expect("hex bits"))
        .collect();
    let std = identified.magnet_std();
    assert_eq!(
        bits,
        [
            host.magnets.depth.to_bits(),
            host.magnets.centre.to_bits(),
            std.to_bits()
        ],
        "{}",
        run.output
    );
    assert!(
        std.is_finite() && (host.magnets.depth - 0.5).abs() <= shared::uncertainty::Z90 * std,
        "depth {} ± {std}",
        host.magnets.depth
    );
    assert!(
        run.output.contains("assessment weak_magnet Faulty"),
        "{}",
        run.output
    );
    assert_eq!(number(&run.output, "magnets ", "pole"), 3, "{}", run.output);
    assert!(
        (host.magnets.depth - 0.5).abs() <= 0.1,
        "{:?}",
        host.magnets
    );
    assert!(host.faults.eccentricity() < 0.05, "{:?}", host.faults);
    // The health log keeps the magnet, its centre and its depth's deviation (rounded up to
    // 1/512), as the host's record of the same reading, after the twelve earlier ones.
    let image = std::fs::read(&log_path).expect("health log written");
    let at = 12 * shared::health::RECORD_BYTES;
    let kept = shared::health::HealthRecord::decode(&image[at..]).expect("a record in slot 12");
    let expected = shared::health::HealthRecord::new(
        12,
        host.faults,
        host.fitness,
        shared::domain::Domain::Within,
    )
    .with_magnet(&host.magnets)
    .with_magnet_std(std);
    assert_eq!(kept.magnet, expected.magnet);
    let kept_std = kept.magnet.std().expect("a deviation kept");
    assert!(
        kept_std >= std && kept_std - std < 1.0 / 512.0,
        "{kept_std} against {std}"
    );
    // The weak magnet's depth is trended on the controller as on the host: the same RUL and
    // interval bits over the same log, from its first magnet read (eight preflights and this
    // one).
    use shared::prognosis::{HealthTrend, TrendSettings, WEAK_MAGNET_TREND};
    let settings = TrendSettings::DEFAULT;
    let (log, _) =
        host_sim::files::health::load_log::<{ shared::health::ONBOARD_RECORDS }>(&log_path)
            .expect("the log reads");
    let e = HealthTrend::from_records(log.iter(), &settings).estimates(&settings)
        [WEAK_MAGNET_TREND]
        .expect("the weak magnet has a trend");
    assert_eq!(e.observations, 9, "from its first magnet read");
    let r = e.rul.expect("the weak magnet has a threshold");
    let hex = |v: Option<f32>| format!("{:08x}", v.map_or(u32::MAX, f32::to_bits));
    let prefix = "trend weak_magnet ";
    assert_eq!(
        field(&run.output, prefix, "rul_bits"),
        hex(r.rul),
        "{}",
        run.output
    );
    assert_eq!(field(&run.output, prefix, "lower_bits"), hex(r.lower));
    assert_eq!(field(&run.output, prefix, "upper_bits"), hex(r.upper));
    assert_eq!(number(&run.output, prefix, "n"), 9);
    // Reached or within a few flights: 0.45 at flight 11 growing by 0.05 a flight.
    assert!(r.rul.is_some_and(|f| f < 5.0), "{r:?}");
}

/// A health log of twelve preflights of a healthy actuator whose magnet at pole 3 starts to
/// lose its flux at flight 4 (0.1, then 0.05 more each flight), each read `within` with a
/// depth's deviation of 0.04.
fn weak_magnet_log() -> Vec<u8> {
    use shared::domain::Domain;
    use shared::health::{HealthRecord, ONBOARD_RECORDS, RECORD_BYTES};
    let params = shared::ActuatorParams::REFERENCE;
    let centre = 3.0 * shared::magnets::pole_pitch(&params);
    let mut image = vec![0xFFu8; ONBOARD_RECORDS * RECORD_BYTES];
    for f in 0..12u32 {
        let depth = if f < 4 {
            0.0
        } else {
            0.1 + 0.05 * (f - 4) as f32
        };
        let record = HealthRecord::new(f, FaultVector::NOMINAL, 0.001, Domain::Within)
            .with_magnet(&shared::magnets::WeakMagnet::new(depth, centre))
            .with_magnet_std(0.04);
        let at = f as usize * RECORD_BYTES;
        image[at..at + RECORD_BYTES].copy_from_slice(&record.encode());
    }
    image
}

/// Friction 0.2 at 50 % I_ref noise, its test played four times (the noise drawn anew each
/// time), on a record that allows three tests: the first test's noise calls for more than
/// one (its fitness over the calibration's healthy mismatch), so the firmware reads the
/// `--again` traces up to the record's three and leaves the fourth. The health log's record
/// is the host's mean of the same three readings (`shared::repeat`), bit for bit, with byte
/// 71 the tests averaged.
#[test]
fn a_noisy_preflight_under_qemu_plays_the_tests_its_noise_calls_for_with_the_hosts_mean() {
    use shared::actuator::ActuatorRecord;
    use shared::domain::DomainLimits;
    use shared::health::HealthRecord;
    use shared::repeat::RepeatedTests;
    let record = ActuatorRecord {
        max_tests: 3,
        ..ActuatorRecord::REFERENCE
    };
    let record_path = temp_trace("repeat.rec", &record.encode());
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let mut host = RepeatedTests::EMPTY;
    let mut paths = Vec::new();
    for (n, seed) in [11u64, 12, 13, 14].into_iter().enumerate() {
        let mut scenario = Scenario::new(
            FaultVector::new([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]).expect("valid"),
        );
        scenario.seed = seed;
        scenario.current_ref_noise = 0.5;
        let trace = rm.simulate(&scenario).trace;
        let bytes = trace.to_bin().expect("encodable");
        paths.push(temp_trace(&format!("repeat-{n}.bin"), &bytes));
        if n < 3 {
            let measured = trace.measured(&record.params).expect("conditioned");
            let id = host_sim::fdi::identify::identify_for(&measured, &record, 1, false)
                .expect("host identification");
            let domain = id.domain(
                &trace.domain_monitor(&record.params),
                &DomainLimits::REFERENCE_ACTUATOR,
            );
            host.add(&id.health_record(0, domain));
        }
    }
    assert_eq!(
        host.called_for(&record),
        3,
        "at 50 % noise the first test calls for more than the three allowed"
    );
    assert_eq!(host.trusted(), 3, "every test within");
    let log_path = temp_trace("repeat-health.bin", &[]);
    std::fs::remove_file(&log_path).expect("no log yet");
    let path = |p: &PathBuf| p.to_str().expect("UTF-8 temp path").to_string();
    let args = [
        path(&paths[0]),
        "--actuator".into(),
        path(&record_path),
        "--again".into(),
        path(&paths[1]),
        "--again".into(),
        path(&paths[2]),
        "--again".into(),
        path(&paths[3]),
        "--health".into(),
        path(&log_path),
    ];
    let run = run_firmware(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(run.status, 0, "firmware failed:\n{}", run.output);
    assert_eq!(
        number(&run.output, "tests ", "called_for"),
        3,
        "{}",
        run.output
    );
    assert_eq!(
        number(&run.output, "tests ", "played"),
        3,
        "the fourth left"
    );
    assert_eq!(number(&run.output, "tests ", "averaged"), 3);
    assert_eq!(
        run.output.matches("\nresult faults=").count(),
        3,
        "{}",
        run.output
    );
    let image = std::fs::read(&log_path).expect("health log written");
    let kept = HealthRecord::decode(&image).expect("the preflight's record in slot 0");
    let mut expected = host.reading();
    expected.flight = 0;
    assert_eq!(kept, expected);
    assert_eq!(kept.fused, 3);
    assert!(
        (kept.faults.friction() - 0.2).abs() < 0.06,
        "{:?}",
        kept.faults
    );
}

#[test]
fn a_corrupted_trace_is_refused_with_a_non_zero_exit() {
    let mut bytes = faulty_trace().to_bin().expect("encodable");
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x01;
    let path = temp_trace("corrupted.bin", &bytes);
    let run = run_firmware(&[path.to_str().expect("UTF-8 temp path")]);
    assert_eq!(run.status, 1, "{}", run.output);
    assert!(run.output.contains("BadChecksum"), "{}", run.output);
    assert!(!run.output.contains("result "), "{}", run.output);
}

#[test]
fn a_missing_trace_and_a_bad_command_line_are_reported() {
    let run = run_firmware(&["/nonexistent/trace.bin"]);
    assert_eq!(run.status, 3, "{}", run.output);
    assert!(run.output.contains("cannot read trace"), "{}", run.output);

    let run = run_firmware(&[]);
    assert_eq!(run.status, 2, "{}", run.output);
    assert!(run.output.contains("usage:"), "{}", run.output);
}

#[test]
fn panic_and_hard_fault_report_and_exit_non_zero() {
    let run = run_firmware(&["--crash", "panic"]);
    assert_eq!(run.status, 101, "{}", run.output);
    assert!(run.output.contains("panic:"), "{}", run.output);

    let run = run_firmware(&["--crash", "hard-fault"]);
    assert_eq!(run.status, 102, "{}", run.output);
    assert!(run.output.contains("hard fault"), "{}", run.output);
}

#[test]
fn a_too_long_trace_is_refused_not_truncated() {
    let trace = faulty_trace();
    let mut long = Trace::with_capacity(TEST_SAMPLES + 10).with_test(*trace.test());
    // Ten rows more than the onboard buffer holds.
    for s in trace.samples().iter().cycle().take(TEST_SAMPLES + 10) {
        long.push(*s);
    }
    let path = temp_trace("long.bin", &long.to_bin().expect("encodable"));
    let run = run_firmware(&[path.to_str().expect("UTF-8 temp path")]);
    assert_eq!(run.status, 1, "{}", run.output);
    assert!(run.output.contains("TooManyFrames"), "{}", run.output);
}

/// The firmware's `bits faults=… fitness=…` line as `u32`s (faults, then fitness).
/// Writes flights 0..12 of a linear path from nominal to [`faulty_trace`]'s vector (reached at
/// flight 12) into a new health log at `path`, as a controller before the ninth fault
/// (record version 4) kept it (32 slots of 76 bytes, eight components): the firmware must
/// carry it over. Returns how many.
fn earlier_flights(path: &Path) -> u32 {
    use shared::domain::Domain;
    use shared::health::{HealthRecord, ONBOARD_RECORDS, RECORD_V3_BYTES};
    let mut image = vec![0xFFu8; ONBOARD_RECORDS * RECORD_V3_BYTES];
    let end = [0.2f32, 0.3, 0.15, 0.0, 0.0, 0.0, 0.5, 0.45];
    let nominal = FaultVector::NOMINAL;
    for f in 0..12u32 {
        let k: Vec<f32> = nominal
            .as_array()
            .iter()
            .zip(end)
            .map(|(a, b)| a + (b - a) * f as f32 / 12.0)
            .collect();
        let k = FaultVector::from_paper(k.try_into().expect("8")).expect("valid");
        let at = f as usize * RECORD_V3_BYTES;
        image[at..at + RECORD_V3_BYTES]
            .copy_from_slice(&HealthRecord::new(f, k, 0.001, Domain::Within).encode_v3());
    }
    std::fs::write(path, image).expect("log written");
    12
}

/// The firmware appended its result as flight 12 of the log, and its trend and RUL lines are
/// the host's (`shared::prognosis` over the same log file), bit for bit.
fn health_matches_the_host(
    output: &str,
    log_path: &Path,
    earlier: u32,
    host: &shared::fdi::IdentificationResult,
    host_uncertainty: &shared::uncertainty::Uncertainty,
    host_day: &shared::conditions::TestConditions,
) {
    use shared::health::ONBOARD_RECORDS;
    use shared::prognosis::{HealthTrend, TrendSettings};
    assert!(
        output.contains(&format!("76-byte slots, {earlier} records carried over")),
        "{output}"
    );
    assert_eq!(number(output, "health ", "flight"), u64::from(earlier));
    assert_eq!(number(output, "health ", "records"), u64::from(earlier) + 1);
    let (log, summary) =
        host_sim::files::health::load_log::<ONBOARD_RECORDS>(log_path).expect("the log reads");
    assert_eq!(summary.damaged, 0);
    let latest = log.latest().expect("a record");
    assert_eq!(latest.flight, earlier);
    assert_eq!(latest.faults, host.faults);
    assert_eq!(latest.fitness.to_bits(), host.fitness.to_bits());
    // The new record carries the identification's standard deviations, as stored (2⁻¹⁶).
    let std = host_uncertainty.std;
    for (i, &sd) in std.iter().enumerate() {
        let kept = latest.std.get(i);
        assert_eq!(kept, shared::health::ComponentStd::new(std).get(i), "{i}");
        if sd.is_finite() {
            // Stored in units of 2⁻¹⁶ below 1 (a larger one saturates there).
            let stored = sd.min(65_534.0 / 65_536.0);
            assert!(
                (kept.unwrap() - stored).abs() <= 1.0 / 131_072.0,
                "{i}: {kept:?} {sd}"
            );
        }
    }
    assert_eq!(
        std::fs::metadata(log_path).expect("log").len(),
        (ONBOARD_RECORDS * shared::health::RECORD_BYTES) as u64,
        "the log is rewritten as version 3"
    );
    // The new record carries the test's day: the measured bus and temperature, the winding's
    // estimated rise, to 0.01.
    let day = latest.day;
    assert_eq!(day, shared::health::RecordedDay::of(host_day));
    assert!(
        day.bus_voltage().is_some_and(|v| (v - 270.0).abs() < 5.0),
        "{day:?}"
    );
    assert!(
        day.temperature().is_some_and(|t| (t - 22.0).abs() < 2.0),
        "{day:?}"
    );
    assert!(day.winding_rise().is_some(), "{day:?}");
    let settings = TrendSettings::DEFAULT;
    let estimates = HealthTrend::from_records(log.iter(), &settings).estimates(&settings);
    let bits = |v: Option<f32>| format!("{:08x}", v.map_or(u32::MAX, f32::to_bits));
    let mut compared = 0;
    for (name, e) in shared::prognosis::TREND_NAMES.iter().zip(estimates) {
        let Some(e) = e else { continue };
        let prefix = format!("trend {name} ");
        let r = e.rul.expect("every trended fault has a threshold");
        assert_eq!(field(output, &prefix, "rul_bits"), bits(r.rul), "{name}");
        assert_eq!(
            field(output, &prefix, "lower_bits"),
            bits(r.lower),
            "{name}"
        );
        assert_eq!(
            field(output, &prefix, "upper_bits"),
            bits(r.upper),
            "{name}"
        );
        assert_eq!(number(output, &prefix, "n"), u64::from(e.observations));
        compared += 1;
    }
    assert_eq!(
        compared, 8,
        "eight fault trends: the paper's seven and demagnetization (no weak magnet was read, \
         so its trend is empty)"
    );
    // Friction grows 0.2/12 per flight: 0.5 is reached near flight 30, ≈ 18 flights on.
    let friction = estimates[0]
        .and_then(|e| e.rul)
        .and_then(|r| r.rul)
        .expect("a RUL");
    assert!((12.0..24.0).contains(&friction), "friction RUL {friction}");
}

fn result_bits(output: &str) -> Vec<u32> {
    let mut bits: Vec<u32> = list(field(output, "bits ", "faults"))
        .iter()
        .map(|x| u32::from_str_radix(x, 16).expect("hex bits"))
        .collect();
    bits.push(u32::from_str_radix(field(output, "bits ", "fitness"), 16).expect("hex"));
    bits
}

fn host_bits(r: &shared::fdi::IdentificationResult) -> Vec<u32> {
    let mut bits: Vec<u32> = r.faults.as_array().iter().map(|x| x.to_bits()).collect();
    bits.push(r.fitness.to_bits());
    bits
}

#[test]
fn a_power_loss_under_qemu_resumes_to_the_same_bits_and_a_damaged_record_restarts() {
    use host_sim::fdi::identify::{identify_checkpointed, Checkpointing, Outcome, Resumption};

    let bytes = faulty_trace().to_bin().expect("encodable");
    let trace = temp_trace("resume.bin", &bytes);
    let trace = trace.to_str().expect("UTF-8 temp path");
    let (measured, host) = host_identification(&bytes);

    // Power lost after 434 evaluations (the GA's budget is 720): exit 5, the record written.
    let record_path = temp_trace("resume.ck", b"");
    std::fs::remove_file(&record_path).expect("no record yet");
    let record_arg = record_path.to_str().expect("UTF-8 temp path");
    let cut = run_firmware(&[trace, "--checkpoint", record_arg, "--stop-after", "434"]);
    assert_eq!(cut.status, 5, "{}", cut.output);
    assert_eq!(number(&cut.output, "stopped ", "evaluations"), 434);
    let record = std::fs::read(&record_path).expect("the record was written");
    assert_eq!(record.len(), 1412);

    // The host resumes the firmware's record to the same bits (one format, one code).
    let copy = temp_trace("resume-host.ck", &record);
    let checkpointing = Checkpointing {
        path: copy,
        every: 500,
        stop_after: None,
    };
    let (outcome, resumption) = identify_checkpointed(
        &measured,
        &shared::actuator::ActuatorRecord::REFERENCE,
        1,
        false,
        Some(&checkpointing),
    )
    .expect("host resumes");
    assert_eq!(resumption, Resumption::Resumed(434));
    let Outcome::Finished(resumed_on_host) = outcome else {
        panic!("no stop requested")
    };
    assert_eq!(host_bits(&resumed_on_host.result), host_bits(&host));

    // Power back: the firmware resumes and finishes with the uninterrupted bits.
    let resumed = run_firmware(&[trace, "--checkpoint", record_arg]);
    assert_eq!(resumed.status, 0, "{}", resumed.output);
    assert_eq!(
        number(&resumed.output, "checkpoint resumed", "evaluations"),
        434
    );
    assert_eq!(result_bits(&resumed.output), host_bits(&host));

    // A damaged record: refused by its checksum, the identification restarts cleanly and
    // still gives the same bits.
    let mut damaged = record.clone();
    damaged[600] ^= 0x20;
    std::fs::write(&record_path, &damaged).expect("written");
    let restarted = run_firmware(&[trace, "--checkpoint", record_arg]);
    assert_eq!(restarted.status, 0, "{}", restarted.output);
    assert!(
        restarted
            .output
            .contains("checkpoint refused reason=Record(BadChecksum"),
        "{}",
        restarted.output
    );
    assert!(!restarted.output.contains("checkpoint resumed"));
    assert_eq!(result_bits(&restarted.output), host_bits(&host));

    // A checkpoint written before the ninth fault (version 1, eight genes, a shorter file)
    // is resumed: the same evaluations, the run finished.
    let mut old = vec![0u8; record.len()];
    let len = shared::ga::as_version_1::<{ shared::fdi::POPULATION }>(&record, &mut old)
        .expect("convertible");
    std::fs::write(&record_path, &old[..len]).expect("written");
    let upgraded = run_firmware(&[trace, "--checkpoint", record_arg]);
    assert_eq!(upgraded.status, 0, "{}", upgraded.output);
    assert_eq!(
        number(&upgraded.output, "checkpoint resumed", "evaluations"),
        434
    );
    assert!(
        upgraded.output.contains("stop_reason "),
        "{}",
        upgraded.output
    );
}

/// The firmware loads an actuator record (`--actuator`) and gives the host's bits for both
/// actuators: the reference one and the light 28 V one (5 pole pairs, gear 200, its own
/// test, calibration and limits). The records carry a small GA budget so that the test
/// stays short; the bits are compared, not the accuracy.
#[test]
fn firmware_with_an_actuator_record_gives_the_hosts_bits_for_both_actuators() {
    use host_sim::files::actuator::Actuator;
    for (file, faults) in [
        (
            "reference.toml",
            [0.0, 0.2, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
        ),
        (
            "light-28v.toml",
            [0.3, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
        ),
    ] {
        let actuator =
            Actuator::load(&workspace_root().join("actuators").join(file)).expect("loads");
        let mut record = actuator.record;
        record.ga.max_evaluations = 300;
        let rm = ReferenceModel::new(actuator.reference_settings().expect("a description"))
            .with_test(record.test);
        let mut scenario = Scenario::new(FaultVector::new(faults).expect("valid"));
        scenario.seed = 5;
        let trace = rm.simulate(&scenario).trace;
        let bytes = trace.to_bin().expect("encodable");
        let trace_path = temp_trace(&format!("{file}.bin"), &bytes);
        let record_path = temp_trace(&format!("{file}.rec"), &record.encode());

        let measured = Trace::from_bin(&bytes)
            .expect("readable")
            .with_test(record.test)
            .measured(&record.params)
            .expect("conditioned");
        let host = host_sim::fdi::identify::identify_for(&measured, &record, 1, false)
            .expect("host identification")
            .result;
        let (after_ga, _) =
            shared::weak_magnet::WeakMagnetSearch::work_after_ga(&record.params, &record.polish);
        assert!(
            (300..=300 + after_ga).contains(&host.evaluations),
            "{}",
            host.evaluations
        );

        let run = run_firmware(&[
            trace_path.to_str().expect("UTF-8"),
            "--actuator",
            record_path.to_str().expect("UTF-8"),
        ]);
        assert_eq!(run.status, 0, "{file}:\n{}", run.output);
        assert!(run.output.contains("actuator record"), "{}", run.output);
        assert_eq!(
            result_bits(&run.output),
            host_bits(&host),
            "{file}:\n{}",
            run.output
        );

        // A damaged record, one of another version, and one for another test are refused
        // with the record's own exit status before any work.
        let mut damaged = record.encode();
        damaged[40] ^= 0x10;
        let damaged_path = temp_trace(&format!("{file}-damaged.rec"), &damaged);
        let mut other_version = record.encode();
        // The version this code writes, plus one.
        other_version[4] = shared::actuator::RECORD_VERSION as u8 + 1;
        let other_version_path = temp_trace(&format!("{file}-newer.rec"), &other_version);
        let mut paper = record;
        paper.test.standstill = None;
        let paper_path = temp_trace(&format!("{file}-paper.rec"), &paper.encode());
        for (path, said) in [
            (&damaged_path, "BadChecksum"),
            (&other_version_path, "UnsupportedVersion"),
            (&paper_path, "paper test"),
        ] {
            let run = run_firmware(&[
                trace_path.to_str().expect("UTF-8"),
                "--actuator",
                path.to_str().expect("UTF-8"),
            ]);
            assert_eq!(run.status, 7, "{file}:\n{}", run.output);
            assert!(run.output.contains(said), "{said}:\n{}", run.output);
            assert!(!run.output.contains("result "), "{}", run.output);
        }
    }
}

/// Issue 34: an actuator whose grease has a drag of its own, calibrated with its friction law
/// by drag (record version 7), on a day its gearbox is 40 K colder than its winding: the
/// firmware reads the chirp's drag, sets the healthy friction and the model's drag from it,
/// and gives the host's bits.
#[test]
fn firmware_with_a_friction_law_by_drag_gives_the_hosts_bits() {
    use host_sim::plant::bridge::ThermalLaws;
    let mut settings = ReferenceSettings::REFERENCE;
    settings.thermal = ThermalLaws::NDFEB_GREASED.with_two_part_grease(&settings.params);
    let mut record = shared::actuator::ActuatorRecord::REFERENCE;
    let rm = ReferenceModel::new(settings).with_test(record.test);
    record.calibration =
        host_sim::fdi::calibration::reference_calibration(&rm, &record.calibration)
            .expect("calibrates");
    assert!(record.calibration.viscous > 0.0, "{:?}", record.calibration);
    record.ga.max_evaluations = 300;
    let mut cold = settings;
    cold.conditions.gear_temperature -= 40.0;
    let mut scenario = Scenario::new(
        FaultVector::new([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]).expect("valid"),
    );
    scenario.seed = 2;
    let trace = ReferenceModel::new(cold)
        .with_test(record.test)
        .simulate(&scenario)
        .trace;
    let bytes = trace.to_bin().expect("encodable");
    let trace_path = temp_trace("drag-law.bin", &bytes);
    let record_path = temp_trace("drag-law.rec", &record.encode());
    let measured = Trace::from_bin(&bytes)
        .expect("readable")
        .with_test(record.test)
        .measured(&record.params)
        .expect("conditioned");
    let day = shared::conditions::TestConditions::estimate(
        &measured,
        &record.params,
        &record.calibration,
    );
    assert!(day.drag_rise > 0.0, "{day:?}");
    let host = host_sim::fdi::identify::identify_for(&measured, &record, 1, false)
        .expect("host identification")
        .result;
    let run = run_firmware(&[
        trace_path.to_str().expect("UTF-8"),
        "--actuator",
        record_path.to_str().expect("UTF-8"),
    ]);
    assert_eq!(run.status, 0, "{}", run.output);
    assert_eq!(result_bits(&run.output), host_bits(&host), "{}", run.output);
}

/// The `f32` bits of `values`, as the firmware prints them (`{:08x}` each).
fn hex_bits(values: &[f32]) -> Vec<String> {
    values
        .iter()
        .map(|v| format!("{:08x}", v.to_bits()))
        .collect()
}

/// Issue 69: a flight's windows on the controller. The reference actuator with friction 0.2
/// and a gain drift of 0.6, twelve flights into a log whose friction grows to it, flies a
/// flight of eight approach windows after its preflight (one of them cannot see the play and
/// stays out of the flight's reading); the emulation image reads the preflight, then each
/// window (`--window`, binary traces with the flight mark) holding the preflight's shorts,
/// eccentricity and demagnetization, and fuses them into the flight's reading: each window's
/// vector, fitness and deviations and the flight's vector and deviations are the bits of
/// `host-sim identify W1 --preflight P --same-flight W2 …`'s code. The flight's reading goes
/// into the health log after the preflight as an in-flight entry (the host's
/// `flight_entry`), and the trend printed after it is the host's over that log, the reading
/// counted. A preflight given as a window is refused.
#[test]
fn a_flights_windows_under_qemu_give_the_hosts_window_and_flight_bits() {
    use host_sim::files::actuator::Actuator;
    use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
    use shared::fusion::{WindowFusion, FLIGHT_MAX_FRICTION_STD};
    use shared::health::{HealthLog, HealthRecord, RamStore, FLIGHT_READING, ONBOARD_RECORDS};
    use shared::prognosis::{HealthTrend, TrendSettings};
    let actuator = Actuator::reference();
    let faults = FaultVector::new([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.6, 0.0]).expect("valid");
    let settings = actuator.reference_settings().expect("the built-in model");
    let ground = ReferenceModel::new(settings).with_test(actuator.record.test);
    let mut scenario = Scenario::new(faults);
    scenario.seed = 3;
    let preflight = ground
        .simulate(&scenario)
        .trace
        .to_bin()
        .expect("encodable");
    let window_test = PreflightTest {
        standstill: None,
        motion: None,
        ..actuator.record.test
    };
    let approach = ReferenceModel::new(settings)
        .with_test(window_test)
        .with_flight(Some(FlightWindow {
            phase: FlightPhase::Approach,
            turbulence: Turbulence::Light,
        }));
    let windows: Vec<Vec<u8>> = (3..11)
        .map(|seed| {
            scenario.seed = seed;
            approach
                .simulate(&scenario)
                .trace
                .to_bin()
                .expect("encodable")
        })
        .collect();
    let preflight_path = temp_trace("flight-preflight.bin", &preflight);
    let window_paths: Vec<PathBuf> = windows
        .iter()
        .enumerate()
        .map(|(j, w)| temp_trace(&format!("flight-window-{j}.bin"), w))
        .collect();
    // Twelve earlier flights, friction growing from 0 to 0.2 and the gain drift to 0.6.
    let mut store = RamStore::<ONBOARD_RECORDS>::erased();
    let mut log = HealthLog::<ONBOARD_RECORDS>::new();
    for f in 0..12u32 {
        let s = f as f32 / 12.0;
        let k = FaultVector::new([0.2 * s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5 + 0.1 * s, 0.0])
            .expect("valid");
        log.append(
            &mut store,
            HealthRecord::new(f, k, 0.001, shared::domain::Domain::Within),
        )
        .expect("appended");
    }
    let log_path = temp_trace("flight-health.bin", store.as_bytes());

    // The host: the preflight identified, what its windows hold of it, each window read and
    // entered into the flight's reading, and the flight's health entry.
    let p = Trace::from_bin(&preflight).expect("readable");
    let record = actuator.record_for(p.test()).expect("the built-in record");
    let measured = p.measured(&record.params).expect("conditioned");
    let pre = host_sim::fdi::identify::identify_for(&measured, &record, 1, false)
        .expect("host identification");
    let within = pre.domain(&p.domain_monitor(&record.params), &record.domain)
        == shared::domain::Domain::Within;
    assert!(within, "a worn actuator's preflight in still air is read");
    let held = host_sim::fdi::window::held_from(&pre, within);
    let mut fusion = WindowFusion::EMPTY;
    let mut host_windows = Vec::new();
    for bytes in &windows {
        let w = Trace::from_bin(bytes).expect("readable");
        assert!(w.is_flight(), "the binary window carries its flight mark");
        let record = actuator.record_for(w.test()).expect("the built-in record");
        let measured = w.measured(&record.params).expect("conditioned");
        let id = host_sim::fdi::window::identify_window(&w, &measured, &record, held, 1)
            .expect("the host reads the window");
        let entered = id.enter(&mut fusion);
        host_windows.push((id, entered));
    }
    let flight = fusion
        .final_reading(FLIGHT_MAX_FRICTION_STD)
        .expect("the windows make a reading");
    assert_eq!(
        flight.verdict,
        Ok(()),
        "a flight of approach windows reads the friction"
    );
    let entered: Vec<_> = host_windows
        .iter()
        .filter(|(_, entered)| *entered)
        .map(|(id, _)| id)
        .collect();
    assert_eq!(entered.len(), 7, "one window cannot see the play");
    let entry = host_sim::fdi::window::flight_entry(12, &flight, &entered);

    let mut args = vec![
        preflight_path.to_str().expect("UTF-8"),
        "--health",
        log_path.to_str().expect("UTF-8"),
    ];
    for w in &window_paths {
        args.extend(["--window", w.to_str().expect("UTF-8")]);
    }
    let run = run_firmware(&args);
    assert_eq!(run.status, 0, "{}", run.output);
    for (n, (id, entered)) in (1..).zip(&host_windows) {
        let prefix = format!("window_bits n={n} ");
        let std = id.uncertainty.as_ref().expect("a deviation").0.std;
        assert_eq!(
            list(field(&run.output, &prefix, "faults")),
            hex_bits(id.faults.as_array()),
            "window {n}:\n{}",
            run.output
        );
        assert_eq!(
            field(&run.output, &prefix, "fitness"),
            format!("{:08x}", id.fitness.to_bits())
        );
        assert_eq!(list(field(&run.output, &prefix, "std")), hex_bits(&std));
        let line = format!("window n={n} ");
        let outcome = format!("outcome=Read {{ entered: {entered} }}");
        let shown = run
            .output
            .lines()
            .find(|l| l.starts_with(&line))
            .expect("the window's line");
        assert!(shown.contains(&outcome), "{shown}");
        assert!(number(&run.output, &line, "longest_poll_instructions") > 0);
        assert!(number(&run.output, &line, "identify_instructions") > 1_000_000_000);
    }
    assert_eq!(
        list(field(&run.output, "flight_bits ", "faults")),
        hex_bits(flight.faults.as_array()),
        "{}",
        run.output
    );
    assert_eq!(
        list(field(&run.output, "flight_bits ", "std")),
        hex_bits(&flight.uncertainty.0.std)
    );
    assert_eq!(number(&run.output, "flight ", "windows"), 8);
    assert_eq!(number(&run.output, "flight ", "entered"), 7);

    // The log: the preflight as flight 12, then the flight's reading, the host's entry.
    let (kept, summary) =
        host_sim::files::health::load_log::<ONBOARD_RECORDS>(&log_path).expect("the log reads");
    assert_eq!(summary.damaged, 0);
    let records: Vec<_> = kept.iter().collect();
    assert_eq!(records.len(), 14);
    assert_eq!((records[12].flight, records[12].window), (12, 0));
    assert_eq!(*records[13], entry, "the flight's entry is the host's");
    assert_eq!((entry.window, entry.fused), (FLIGHT_READING, 7));
    assert!(entry.is_trusted());
    // The trend after the reading: the host's over the same log, bit for bit, the reading
    // one more observation than after the preflight.
    let after = &run.output[run
        .output
        .find("health flight=12 entry=reading")
        .expect("the reading logged")..];
    let trend = TrendSettings::DEFAULT;
    let estimates = HealthTrend::from_records(kept.iter(), &trend).estimates(&trend);
    let friction = estimates[0].expect("the friction is trended");
    let bits = |v: Option<f32>| format!("{:08x}", v.map_or(u32::MAX, f32::to_bits));
    let rul = friction.rul.expect("a threshold");
    assert_eq!(field(after, "trend friction ", "rul_bits"), bits(rul.rul));
    assert_eq!(
        field(after, "trend friction ", "lower_bits"),
        bits(rul.lower)
    );
    assert_eq!(
        field(after, "trend friction ", "upper_bits"),
        bits(rul.upper)
    );
    assert_eq!(
        number(after, "trend friction ", "n"),
        number(&run.output, "trend friction ", "n") + 1
    );

    // A preflight trace is no window: refused after the preflight, before any window work.
    let run = run_firmware(&[
        preflight_path.to_str().expect("UTF-8"),
        "--window",
        preflight_path.to_str().expect("UTF-8"),
    ]);
    assert_eq!(run.status, 3, "{}", run.output);
    assert!(run.output.contains("NotAWindow"), "{}", run.output);
}
