//! Unit tests of [`super`] (`actuator`).

use super::*;

#[test]
fn the_reference_record_round_trips_bit_for_bit() {
    let bytes = ActuatorRecord::REFERENCE.encode();
    assert_eq!(bytes.len(), RECORD_BYTES);
    let back = ActuatorRecord::decode(&bytes).unwrap();
    assert_eq!(back, ActuatorRecord::REFERENCE);
    assert_eq!(back.encode(), bytes);
}

/// A record of an older `version` whose body is `body`: header, body, CRC-32.
fn older_record(version: u16, body: &[u8]) -> Vec<u8> {
    let mut out = RECORD_MAGIC.to_vec();
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(body.len() as u16).to_le_bytes());
    out.extend_from_slice(body);
    let mut crc = Crc32::new();
    crc.update(&out);
    out.extend_from_slice(&crc.finish().to_le_bytes());
    out
}

#[test]
fn a_version_1_record_reads_as_steps_without_the_days_terms() {
    // Version 1: the body without the day's words and the ranges.
    let steps = ActuatorRecord {
        test: PreflightTest::STANDSTILL,
        calibration: Calibration::REFERENCE_ACTUATOR_STEPS,
        ..ActuatorRecord::REFERENCE
    };
    let v3 = steps.encode();
    let split = 8 + 4 * (BODY_WORDS_V1 - 7); // the day's words come before 7 domain words
    let domain = 8 + 4 * (BODY_WORDS_V2 - 7);
    let mut body = v3[8..split].to_vec();
    body.extend_from_slice(&v3[domain..domain + 4 * 7]);
    let v1 = older_record(1, &body);
    assert_eq!(v1.len(), RECORD_BYTES_V1);
    let r = ActuatorRecord::decode(&v1).unwrap();
    assert_eq!(r.params, ActuatorRecord::REFERENCE.params);
    assert_eq!(r.test.standstill.map(|s| s.frequency), Some(0.0));
    assert_eq!(
        r.calibration.resistance_scale,
        steps.calibration.resistance_scale
    );
    assert_eq!(r.calibration.pair_resistance_scale, 1.0);
    assert_eq!(
        (r.domain.bus_voltage, r.domain.temperature),
        DomainLimits::ANY_DAY
    );
    assert_eq!(
        ActuatorRecord::decode(&v1[..200]),
        Err(ActuatorRecordError::TooShort { found: 200 })
    );
}

#[test]
fn a_version_2_record_reads_with_any_day() {
    let v4 = ActuatorRecord::REFERENCE.encode();
    let v2 = older_record(2, &v4[8..8 + 4 * BODY_WORDS_V2]);
    assert_eq!(v2.len(), RECORD_BYTES_V2);
    let r = ActuatorRecord::decode(&v2).unwrap();
    let (bus_voltage, temperature) = DomainLimits::ANY_DAY;
    let expected = ActuatorRecord {
        domain: DomainLimits {
            bus_voltage,
            temperature,
            ..ActuatorRecord::REFERENCE.domain
        },
        ..ActuatorRecord::REFERENCE
    };
    assert_eq!(r, expected);
}

#[test]
fn a_version_3_record_reads_with_the_flown_polish() {
    let custom = ActuatorRecord {
        polish: PolishSettings {
            iterations: 3,
            probe_count: 1,
            ..PolishSettings::FDI
        },
        ..ActuatorRecord::REFERENCE
    };
    let v4 = custom.encode();
    assert_eq!(ActuatorRecord::decode(&v4), Ok(custom));
    let v3 = older_record(3, &v4[8..8 + 4 * BODY_WORDS_V3]);
    assert_eq!(v3.len(), RECORD_BYTES_V3);
    let r = ActuatorRecord::decode(&v3).unwrap();
    assert_eq!(r.polish, PolishSettings::FDI);
    assert_eq!(r.domain, custom.domain);
    let mut bad = custom;
    bad.polish.probes[0].component = 6; // the phase is no probe
    assert_eq!(
        bad.validate(),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::Polish
        })
    );
}

#[test]
fn a_version_4_record_reads_with_the_typical_drive() {
    let custom = ActuatorRecord {
        drive: DriveSettings {
            carrier_hz: 16_000.0,
            dead_time: 1.0e-6,
            compensation: false,
            compensation_threshold: 0.0,
        },
        ..ActuatorRecord::REFERENCE
    };
    let v6 = custom.encode();
    assert_eq!(ActuatorRecord::decode(&v6), Ok(custom));
    let v4 = older_record(4, &v6[8..8 + 4 * BODY_WORDS_V4]);
    assert_eq!(v4.len(), RECORD_BYTES_V4);
    let r = ActuatorRecord::decode(&v4).unwrap();
    assert_eq!(r.drive, DriveSettings::TYPICAL);
    assert_eq!(r.polish, custom.polish);
    // A compensation word other than 0 or 1, re-sealed: refused, not read as "on".
    let mut flag = v6;
    let at = RECORD_BYTES
        - 4
        - 12
        - 4 * (GREASE_WORDS + NINTH_WORDS + SYSTEMATIC_WORDS + SPREAD_WORDS + TESTS_WORDS);
    flag[at..at + 4].copy_from_slice(&7u32.to_le_bytes());
    let mut crc = Crc32::new();
    crc.update(&flag[..RECORD_BYTES - 4]);
    flag[RECORD_BYTES - 4..].copy_from_slice(&crc.finish().to_le_bytes());
    assert_eq!(
        ActuatorRecord::decode(&flag),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::DriveCompensationThreshold
        })
    );
    let mut negative = custom;
    negative.drive.compensation_threshold = -0.1;
    assert_eq!(
        negative.validate(),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::DriveCompensationThreshold
        })
    );
    let mut slow = custom;
    slow.drive.dead_time = 7.0e-6; // over a tenth of the 62.5 µs period
    assert_eq!(
        slow.validate(),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::DriveDeadTime
        })
    );
}

#[test]
fn a_version_7_record_reads_with_no_demagnetization_in_its_guess() {
    let mut custom = ActuatorRecord::REFERENCE;
    let mut guess = *FaultVector::NOMINAL.as_array();
    guess[0] = 0.1;
    guess[8] = 0.2;
    custom.ga.initial_guess = Some(guess);
    assert_eq!(custom.validate(), Ok(()));
    let v8 = custom.encode();
    assert_eq!(v8.len(), RECORD_BYTES);
    assert_eq!(ActuatorRecord::decode(&v8), Ok(custom));
    let v7 = older_record(7, &v8[8..8 + 4 * BODY_WORDS_V7]);
    assert_eq!(v7.len(), RECORD_BYTES_V7);
    let r = ActuatorRecord::decode(&v7).unwrap();
    let mut eight = guess;
    eight[8] = 0.0;
    assert_eq!(r.ga.initial_guess, Some(eight));
    assert_eq!(
        (r.calibration, r.drive, r.polish),
        (custom.calibration, custom.drive, custom.polish)
    );
    // Without a guess the ninth word is not read into one.
    custom.ga.initial_guess = None;
    assert_eq!(ActuatorRecord::decode(&custom.encode()), Ok(custom));
}

#[test]
fn a_version_9_record_reads_with_the_gearbox_at_the_thermistors_temperature() {
    let custom = ActuatorRecord {
        systematic: SystematicError {
            gear_temperature_spread: 12.0,
            ..SystematicError::REFERENCE_ACTUATOR
        },
        ..ActuatorRecord::REFERENCE
    };
    let v10 = custom.encode();
    assert_eq!(ActuatorRecord::decode(&v10), Ok(custom));
    let v9 = older_record(9, &v10[8..8 + 4 * BODY_WORDS_V9]);
    assert_eq!(v9.len(), RECORD_BYTES_V9);
    let r = ActuatorRecord::decode(&v9).unwrap();
    assert_eq!(r.systematic.gear_temperature_spread, 0.0);
    assert_eq!(r, ActuatorRecord::REFERENCE);
    let bad = ActuatorRecord {
        systematic: SystematicError {
            gear_temperature_spread: -1.0,
            ..custom.systematic
        },
        ..custom
    };
    assert_eq!(
        ActuatorRecord::decode(&bad.encode()),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::UncertaintyGearTemperatureSpread
        })
    );
}

#[test]
fn a_version_10_record_reads_as_one_test_a_preflight() {
    let custom = ActuatorRecord {
        max_tests: 4,
        ..ActuatorRecord::REFERENCE
    };
    let v11 = custom.encode();
    assert_eq!(ActuatorRecord::decode(&v11), Ok(custom));
    let v10 = older_record(10, &v11[8..8 + 4 * BODY_WORDS_V10]);
    assert_eq!(v10.len(), RECORD_BYTES_V10);
    assert_eq!(ActuatorRecord::decode(&v10), Ok(ActuatorRecord::REFERENCE));
    for max_tests in [0, MAX_TESTS + 1] {
        let bad = ActuatorRecord {
            max_tests,
            ..custom
        };
        assert_eq!(
            ActuatorRecord::decode(&bad.encode()),
            Err(ActuatorRecordError::OutOfRange {
                field: RecordField::TestMaxTests
            })
        );
    }
}

#[test]
fn the_noise_calls_for_tests_by_its_share_of_the_residual() {
    let with = |max_tests, nominal_residual| ActuatorRecord {
        max_tests,
        calibration: Calibration {
            nominal_residual,
            ..Calibration::REFERENCE_ACTUATOR
        },
        ..ActuatorRecord::REFERENCE
    };
    let nominal = 0.0139;
    let four = with(4, nominal);
    assert_eq!(four.tests_called_for(0.001), 1, "noise-free");
    assert_eq!(four.tests_called_for(nominal), 1, "at the mismatch");
    assert_eq!(four.tests_called_for(0.015), 2);
    assert_eq!(four.tests_called_for(2.0 * nominal), 2, "a whole ratio");
    assert_eq!(four.tests_called_for(0.03), 3);
    assert_eq!(four.tests_called_for(0.06), 4, "capped");
    assert_eq!(four.tests_called_for(f32::NAN), 1);
    assert_eq!(four.tests_called_for(f32::INFINITY), 4);
    assert_eq!(with(8, nominal).tests_called_for(0.06), 5);
    assert_eq!(
        with(1, nominal).tests_called_for(0.06),
        1,
        "one test allowed"
    );
    assert_eq!(
        with(0, nominal).tests_called_for(0.06),
        1,
        "0 reads as one test"
    );
    assert_eq!(with(100, nominal).tests_called_for(9.0), MAX_TESTS);
    assert_eq!(
        with(4, 0.0).tests_called_for(0.01),
        4,
        "no mismatch to reach"
    );
    assert_eq!(ActuatorRecord::REFERENCE.tests_called_for(0.06), 1);
}

#[test]
fn a_version_8_record_reads_with_the_reference_actuators_systematic_error() {
    let custom = ActuatorRecord {
        systematic: SystematicError {
            gain_drift: 0.009,
            play_gain_drift: 0.018,
            gear_temperature_spread: 0.0,
            healthy_friction: 0.0,
        },
        ..ActuatorRecord::REFERENCE
    };
    let v10 = custom.encode();
    assert_eq!(ActuatorRecord::decode(&v10), Ok(custom));
    let v8 = older_record(8, &v10[8..8 + 4 * BODY_WORDS_V8]);
    assert_eq!(v8.len(), RECORD_BYTES_V8);
    let r = ActuatorRecord::decode(&v8).unwrap();
    assert_eq!(r.systematic, SystematicError::REFERENCE_ACTUATOR);
    assert_eq!(
        ActuatorRecord {
            systematic: custom.systematic,
            ..r
        },
        custom
    );
    for (gain_drift, play_gain_drift, field) in [
        (-0.001, 0.018, RecordField::UncertaintyGainDriftSystematic),
        (
            0.009,
            f32::NAN,
            RecordField::UncertaintyPlayGainDriftSystematic,
        ),
    ] {
        let bad = ActuatorRecord {
            systematic: SystematicError {
                gain_drift,
                play_gain_drift,
                gear_temperature_spread: 0.0,
                healthy_friction: 0.0,
            },
            ..custom
        };
        assert_eq!(
            ActuatorRecord::decode(&bad.encode()),
            Err(ActuatorRecordError::OutOfRange { field })
        );
    }
}

#[test]
fn a_version_6_record_reads_without_a_friction_law_by_drag() {
    let mut custom = ActuatorRecord::REFERENCE;
    custom.calibration.duty_delay = 5.0e-5;
    custom.calibration.viscous = 0.0123;
    custom.calibration.drag_points = [6.5, 3.2, 1.9, 0.5];
    assert_eq!(custom.validate(), Ok(()));
    let v7 = custom.encode();
    assert_eq!(ActuatorRecord::decode(&v7), Ok(custom));
    let v6 = older_record(6, &v7[8..8 + 4 * BODY_WORDS_V6]);
    assert_eq!(v6.len(), RECORD_BYTES_V6);
    let r = ActuatorRecord::decode(&v6).unwrap();
    assert_eq!(r.calibration.viscous, 0.0);
    assert_eq!(r.calibration.drag_points, [0.0; 4]);
    assert_eq!(r.calibration.duty_delay, 5.0e-5);
    for (bad, field) in [
        (-1.0, RecordField::CalibrationViscous),
        (f32::NAN, RecordField::CalibrationViscous),
    ] {
        let mut c = custom;
        c.calibration.viscous = bad;
        assert_eq!(c.validate(), Err(ActuatorRecordError::OutOfRange { field }));
    }
    let mut rising = custom;
    rising.calibration.friction_points = ActuatorRecord::REFERENCE.calibration.friction_points;
    rising.calibration.drag_points = [6.5, 7.0, 1.9, 0.5];
    assert_eq!(
        rising.validate(),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::CalibrationDragPoints
        })
    );
    let mut c = custom;
    c.calibration.drag_points[2] = 1.0e3;
    assert_eq!(
        c.validate(),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::CalibrationDragPoints
        })
    );
}

#[test]
fn a_version_5_record_reads_with_a_controller_that_applies_its_volts_at_the_sample() {
    let mut custom = ActuatorRecord::REFERENCE;
    custom.calibration.duty_delay = 5.0e-5;
    let v6 = custom.encode();
    assert_eq!(ActuatorRecord::decode(&v6), Ok(custom));
    let v5 = older_record(5, &v6[8..8 + 4 * BODY_WORDS_V5]);
    assert_eq!(v5.len(), RECORD_BYTES_V5);
    let r = ActuatorRecord::decode(&v5).unwrap();
    assert_eq!(r.calibration.duty_delay, 0.0);
    assert_eq!(r.drive, custom.drive);
    assert_eq!(
        r,
        ActuatorRecord {
            calibration: ActuatorRecord::REFERENCE.calibration,
            ..custom
        }
    );
    // One control period is the latest a controller loads its volts; later is refused.
    custom.calibration.duty_delay = custom.params.control_period;
    assert_eq!(custom.validate(), Ok(()));
    for late in [1.5e-4, -1.0e-6, f32::NAN] {
        custom.calibration.duty_delay = late;
        assert_eq!(
            custom.validate(),
            Err(ActuatorRecordError::OutOfRange {
                field: RecordField::CalibrationDutyDelay
            }),
            "{late}"
        );
    }
}

#[test]
fn an_inverted_range_is_refused() {
    let mut r = ActuatorRecord::REFERENCE;
    r.domain.temperature = [90.0, -40.0];
    assert_eq!(
        r.validate(),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::DomainTemperature
        })
    );
    r.domain.temperature = [-40.0, 90.0];
    r.domain.bus_voltage = [f32::NAN, 300.0];
    assert_eq!(
        r.validate(),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::DomainBusVoltage
        })
    );
}

#[test]
fn record_fields_have_distinct_keys() {
    for (i, a) in RecordField::ALL.iter().enumerate() {
        assert!(
            a.key().split('.').all(|part| !part.is_empty()),
            "{a:?}: {}",
            a.key()
        );
        for b in &RecordField::ALL[i + 1..] {
            assert_ne!(a.key(), b.key(), "{a:?} and {b:?}");
        }
    }
}

#[test]
fn every_flipped_bit_is_refused() {
    let bytes = ActuatorRecord::REFERENCE.encode();
    for i in 0..RECORD_BYTES * 8 {
        let mut damaged = bytes;
        damaged[i / 8] ^= 1 << (i % 8);
        assert!(ActuatorRecord::decode(&damaged).is_err(), "bit {i}");
    }
}

#[test]
fn header_errors_are_named() {
    let bytes = ActuatorRecord::REFERENCE.encode();
    assert_eq!(
        ActuatorRecord::decode(&bytes[..100]),
        Err(ActuatorRecordError::TooShort { found: 100 })
    );
    let mut other = bytes;
    other[4] = 12;
    assert_eq!(
        ActuatorRecord::decode(&other),
        Err(ActuatorRecordError::UnsupportedVersion { found: 12 })
    );
    let mut other = bytes;
    other[0] = b'X';
    assert_eq!(
        ActuatorRecord::decode(&other),
        Err(ActuatorRecordError::BadMagic)
    );
}

#[test]
fn out_of_range_values_are_refused_even_with_a_good_checksum() {
    let mut r = ActuatorRecord::REFERENCE;
    r.params.gear_ratio = 0.0;
    assert_eq!(
        ActuatorRecord::decode(&r.encode()),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::MechanicsGearRatio
        })
    );
    let mut r = ActuatorRecord::REFERENCE;
    r.params.motor_inertia = -1e-4;
    assert_eq!(
        r.validate(),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::MechanicsMotorInertia
        })
    );
    let mut r = ActuatorRecord::REFERENCE;
    r.test.chirp.duration = 1.0; // 10 000 samples: more than the buffer holds
    assert_eq!(
        r.validate(),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::TestChirpDuration
        })
    );
    let mut r = ActuatorRecord::REFERENCE;
    r.params.pole_pairs = 4.5;
    assert!(r.validate().is_err());
    // Found by fuzzing: a chirp too long to count (usize::MAX samples) beside a standstill
    // segment overflowed the sum instead of being refused.
    let mut r = ActuatorRecord::REFERENCE;
    r.test.chirp.duration = 3.0e38;
    assert_eq!(
        ActuatorRecord::decode(&r.encode()),
        Err(ActuatorRecordError::OutOfRange {
            field: RecordField::TestChirpDuration
        })
    );
}
