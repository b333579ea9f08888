//! Unit tests of [`super`] (`health`).

use super::*;

fn record(flight: u32, friction: f32) -> HealthRecord {
    let mut k = *FaultVector::NOMINAL.as_array();
    k[0] = friction;
    HealthRecord::new(flight, FaultVector::new(k).unwrap(), 0.01, Domain::Within)
}

#[test]
fn record_round_trips_and_every_byte_is_covered() {
    let r = HealthRecord::new(
        7,
        FaultVector::new([0.3, 0.01, 0.2, 0.0, 0.0, 0.1, 0.25, 0.6, 0.2]).unwrap(),
        0.0123,
        Domain::Outside(OutsideReason::NoMotion { travel: 1e-4 }),
    );
    // Friction, short A, eccentricity 0.1, gain drift 0.6 and demagnetization 0.2 are
    // beyond 0.05 of nominal.
    assert_eq!(r.detected, 0b1_1010_0101);
    let bytes = r.encode();
    assert_eq!(&bytes[..4], b"EMAH");
    assert_eq!(HealthRecord::decode(&bytes), Ok(r));
    every_byte_counts(&bytes);
}

/// Damage to any byte of `bytes` is refused.
fn every_byte_counts(bytes: &EncodedRecord) {
    for i in 0..RECORD_BYTES {
        let mut b = *bytes;
        b[i] ^= 0x10;
        assert!(
            HealthRecord::decode(&b).is_err(),
            "byte {i} damage accepted"
        );
    }
}

#[test]
fn a_weak_magnet_is_stored_and_a_version_4_record_still_reads() {
    use crate::magnets::WeakMagnet;
    let magnets = WeakMagnet::new(0.5, 3.0 * core::f32::consts::PI / 4.0);
    let r = record(9, 0.2).with_magnet(&magnets);
    let bytes = r.encode();
    assert_eq!(bytes[4], RECORD_VERSION);
    let back = HealthRecord::decode(&bytes).unwrap();
    assert_eq!(back, r);
    let read = back.magnet.magnets();
    assert!((read.depth - 0.5).abs() <= 1.0 / 255.0, "{read:?}");
    assert!((read.centre - magnets.centre).abs() <= core::f32::consts::PI / 256.0);
    assert_eq!(read.pole(&crate::ActuatorParams::default()), 3);
    // Every byte still counts, the magnet's two among them.
    every_byte_counts(&bytes);
    // What a controller before version 5 wrote: the same record, no magnet.
    let v4 = r.encode_v4();
    assert_eq!(v4[4], 4);
    let old = HealthRecord::decode(&v4).unwrap();
    assert_eq!(old.magnet, RecordedMagnet::NONE);
    assert_eq!(
        HealthRecord {
            magnet: r.magnet,
            ..old
        },
        r
    );
    // A version-4 record never had bytes 78–79: set, it is refused.
    let mut forged = v4;
    forged[78] = 1;
    let mut crc = crate::trace::Crc32::new();
    crc.update(&forged[..RECORD_BYTES - 4]);
    forged[RECORD_BYTES - 4..].copy_from_slice(&crc.finish().to_le_bytes());
    assert_eq!(
        HealthRecord::decode(&forged),
        Err(HealthRecordError::BadField)
    );
    // No magnet read: none stored, whatever its centre was.
    assert_eq!(RecordedMagnet::of(&WeakMagnet::NONE), RecordedMagnet::NONE);
}

/// Re-seals `bytes` with the CRC of their first `RECORD_BYTES − 4`.
fn resealed(mut bytes: EncodedRecord) -> EncodedRecord {
    let mut crc = crate::trace::Crc32::new();
    crc.update(&bytes[..RECORD_BYTES - 4]);
    bytes[RECORD_BYTES - 4..].copy_from_slice(&crc.finish().to_le_bytes());
    bytes
}

#[test]
fn a_weak_magnets_deviation_is_stored_rounded_up_and_a_version_5_record_still_reads() {
    use crate::magnets::WeakMagnet;
    let magnets = WeakMagnet::new(0.5, 1.0);
    // Demagnetization set too: its detected bit shares byte 7 with the deviation.
    let mut k = *FaultVector::NOMINAL.as_array();
    k[DEMAGNETIZATION_INDEX] = 0.3;
    let r = HealthRecord::new(4, FaultVector::new(k).unwrap(), 0.01, Domain::Within)
        .with_magnet(&magnets)
        .with_magnet_std(0.0322);
    assert_eq!(r.detected, 1 << DEMAGNETIZATION_INDEX);
    let bytes = r.encode();
    let back = HealthRecord::decode(&bytes).unwrap();
    assert_eq!(back, r);
    // 0.0322·512 = 16.49: 17/512, never below the deviation.
    let std = back.magnet.std().unwrap();
    assert_eq!(std, 17.0 / 512.0);
    assert!(std >= 0.0322);
    assert_eq!(back.detected, 1 << DEMAGNETIZATION_INDEX);
    every_byte_counts(&bytes);
    // The scale's ends: a tiny deviation is 1/512, a large one 127/512; none that is not a
    // number, and none without a magnet.
    assert_eq!(r.with_magnet_std(1e-6).magnet.std(), Some(1.0 / 512.0));
    assert_eq!(r.with_magnet_std(0.9).magnet.std(), Some(127.0 / 512.0));
    assert_eq!(r.with_magnet_std(f32::NAN).magnet.std(), None);
    assert_eq!(
        record(1, 0.0).with_magnet_std(0.03).magnet,
        RecordedMagnet::NONE
    );
    // What a controller before version 6 wrote: the magnet without its deviation.
    let v5 = r.encode_v5();
    assert_eq!(v5[4], 5);
    let old = HealthRecord::decode(&v5).unwrap();
    assert_eq!(old.magnet.std(), None);
    assert_eq!(old.magnet.magnets(), r.magnet.magnets());
    assert_eq!(old.detected, r.detected);
    // A version-5 record never had byte 7's upper bits: set, it is refused.
    let mut forged = v5;
    forged[7] |= 0x40;
    assert_eq!(
        HealthRecord::decode(&resealed(forged)),
        Err(HealthRecordError::BadField)
    );
    // A deviation without a magnet is refused.
    let mut forged = record(2, 0.1).encode();
    forged[7] |= 0x10;
    assert_eq!(
        HealthRecord::decode(&resealed(forged)),
        Err(HealthRecordError::BadField)
    );
}

#[test]
fn every_domain_reason_is_stored_by_its_own_code_and_name() {
    use OutsideReason as R;
    let reasons = [
        R::NoMotion { travel: 0.0 },
        R::OpenPhase {
            phase: 0,
            ratio: 0.0,
        },
        R::CommandMismatch { tracking: 0.0 },
        R::FitnessFloor { fitness: 0.0 },
        R::SegmentCarriedNothing { pair: 0 },
        R::BusOutOfRange { volts: 0.0 },
        R::TemperatureOutOfRange { celsius: 0.0 },
        R::EncoderStuck { samples: 0 },
        R::EncoderGlitch { step: 0.0 },
        R::CurrentSenseOffset { amps: 0.0 },
        R::CurrentSenseGain { amps: 0.0 },
        R::TransducerDisagrees { spread: 0.0 },
        R::InstallationChanged { kelvin: 0.0 },
        R::GreaseOutOfRange { drag: f32::NAN },
        R::LoadMoved { offset: 0.1 },
        R::LoadMovedAtRest { travel: 0.1 },
    ];
    assert_eq!(DomainCode::from(Domain::Within), DomainCode::Within);
    for (i, reason) in reasons.into_iter().enumerate() {
        let code = DomainCode::from(Domain::Outside(reason));
        // Codes are the stored bytes: in order, none reused, never changed.
        assert_eq!(code as u8 as usize, i + 1, "{reason:?}");
        assert_eq!(DomainCode::from_byte(code as u8), Some(code));
        assert_eq!(DomainCode::from_name(code.name()), Some(code));
        let r = HealthRecord::new(3, FaultVector::NOMINAL, 0.01, Domain::Outside(reason));
        assert_eq!(
            HealthRecord::decode(&r.encode()).map(|r| r.domain),
            Ok(code)
        );
    }
    // A window of flight's own reasons follow; its fit's floor is the preflight's code.
    use crate::flight::window::WindowReason as W;
    let windows = [
        W::CurrentSaturated { peak: 1.0 },
        W::ManoeuvreTooLarge { range: 1.0 },
        W::PlayUnseen { contrast: 0.1 },
        W::TurbulenceTooHigh { friction_std: 0.2 },
        W::Unconfirmed {
            windows: 1,
            disagreement: f32::NAN,
        },
    ];
    for (i, reason) in windows.into_iter().enumerate() {
        let code = DomainCode::from(Err(reason));
        assert_eq!(code as u8 as usize, reasons.len() + 1 + i, "{reason:?}");
        assert_eq!(DomainCode::from_byte(code as u8), Some(code));
        assert_eq!(DomainCode::from_name(code.name()), Some(code));
    }
    assert_eq!(
        DomainCode::from(Err(W::FitnessFloor { misfit: 0.2 })),
        DomainCode::FitnessFloor
    );
    assert_eq!(DomainCode::from(Ok(())), DomainCode::Within);
    assert_eq!(DomainCode::from_byte(22), None);
}

#[test]
fn an_in_flight_entry_is_kept_in_byte_70_and_an_older_record_reads_as_a_preflight() {
    let r = record(9, 0.2).in_flight(3);
    let bytes = r.encode();
    assert_eq!(bytes[70], 3);
    let back = HealthRecord::decode(&bytes).unwrap();
    assert_eq!((back.window, back.flight), (3, 9));
    assert_eq!(back, r);
    // Every record written before in-flight entries has a 0 there: a preflight.
    let before = record(9, 0.2).encode();
    assert_eq!(before[70], 0);
    assert_eq!(HealthRecord::decode(&before).map(|r| r.window), Ok(0));
    // Byte 71 is a flight's reading's and a repeated preflight's: a window's with it set is
    // refused.
    let resealed = |mut b: EncodedRecord| {
        let mut crc = Crc32::new();
        crc.update(&b[..RECORD_BYTES - 4]);
        b[RECORD_BYTES - 4..].copy_from_slice(&crc.finish().to_le_bytes());
        b
    };
    let mut b = bytes;
    b[71] = 1;
    assert_eq!(
        HealthRecord::decode(&resealed(b)),
        Err(HealthRecordError::BadField)
    );
    // A preflight of four tests averaged: byte 70 0, byte 71 4.
    let mut repeated = record(9, 0.2);
    repeated.fused = 4;
    let b = repeated.encode();
    assert_eq!((b[70], b[71]), (0, 4));
    assert_eq!(HealthRecord::decode(&b), Ok(repeated));
    // A flight's reading: byte 70 255, byte 71 the windows fused.
    let flight = record(9, 0.2).flight_reading(6);
    let bytes = flight.encode();
    assert_eq!((bytes[70], bytes[71]), (FLIGHT_READING, 6));
    assert_eq!(HealthRecord::decode(&bytes), Ok(flight));
    assert_eq!((flight.window, flight.fused), (255, 6));
    // The onboard log and store keep preflights and flights' readings, not a window's own
    // entry: flight 9's preflight, its reading, flight 10's preflight, in that order.
    let mut store = RamStore::<4>::erased();
    let mut log = HealthLog::<4>::new();
    assert_eq!(
        log.append(&mut store, r),
        Err(HealthLogError::InFlightEntry)
    );
    let preflight = record(9, 0.2);
    let next = record(10, 0.2);
    for entry in [preflight, flight, next] {
        assert_eq!(log.append(&mut store, entry), Ok(None));
    }
    assert!(preflight.order() < r.order() && r.order() < flight.order());
    // Not after the newest: refused, by the log and by the store alike.
    assert_eq!(
        log.append(&mut store, flight),
        Err(HealthLogError::NotNewer { last: 10 })
    );
    assert_eq!(
        write_slot(&mut store, &flight),
        Err(HealthLogError::NotNewer { last: 10 })
    );
    let (loaded, summary) = HealthLog::<4>::load(&mut store).unwrap();
    assert_eq!(summary.records, 3);
    assert_eq!(
        loaded
            .iter()
            .map(|r| (r.flight, r.window))
            .collect::<Vec<_>>(),
        [(9, 0), (9, FLIGHT_READING), (10, 0)]
    );
}

#[test]
fn version_2_keeps_the_standard_deviations_and_version_1_is_still_read() {
    let std = [
        0.012,
        0.5,
        f32::NAN,
        0.0,
        2.0,
        0.03,
        f32::NAN,
        -1.0,
        f32::NAN,
    ];
    let r = record(9, 0.3).with_std(std);
    assert_eq!(r.std.get(0), Some(786.0 / 65_536.0)); // 0.012 rounded to 2⁻¹⁶
    assert_eq!(r.std.get(1), Some(0.5));
    assert_eq!(r.std.get(2), None);
    assert_eq!(r.std.get(3), Some(0.0));
    assert_eq!(r.std.get(4), Some(65_534.0 / 65_536.0));
    assert_eq!(r.std.get(7), None);
    let v4 = r.encode_v4();
    assert_eq!(v4[4], 4);
    assert_eq!(HealthRecord::decode(&v4), Ok(r));
    let v3 = r.encode_v3();
    assert_eq!(HealthRecord::decode(&v3), Ok(r));
    let v2 = r.encode_v2();
    assert_eq!(v2[4], 2);
    assert_eq!(HealthRecord::decode(&v2), Ok(r)); // no day either way
    let v1 = r.encode_v1();
    assert_eq!(v1[4], 1);
    let old = HealthRecord::decode(&v1).unwrap();
    assert_eq!(old.std, ComponentStd::UNKNOWN);
    assert_eq!(
        (old.flight, old.faults, old.fitness),
        (r.flight, r.faults, r.fitness)
    );
    // A version-1 record in an 84-byte slot (the rest erased) reads the same.
    let mut slot = [0xFF; RECORD_BYTES];
    slot[..RECORD_V1_BYTES].copy_from_slice(&v1);
    assert_eq!(HealthRecord::decode(&slot), Ok(old));
    // An unknown version is named, not mistaken for damage.
    let mut v6 = v4;
    v6[4] = RECORD_VERSION + 1;
    assert_eq!(
        HealthRecord::decode(&v6),
        Err(HealthRecordError::UnsupportedVersion(RECORD_VERSION + 1))
    );
    // A version-1 record cut short fails its checksum.
    assert_eq!(
        HealthRecord::decode(&v1[..40]),
        Err(HealthRecordError::BadChecksum)
    );
}

/// `bytes` with byte `at` set to `value` and the CRC-32 made good again.
fn forged<const N: usize>(mut bytes: [u8; N], at: usize, value: u8) -> [u8; N] {
    bytes[at] = value;
    let mut crc = Crc32::new();
    crc.update(&bytes[..N - 4]);
    bytes[N - 4..].copy_from_slice(&crc.finish().to_le_bytes());
    bytes
}

#[test]
fn version_4_keeps_the_demagnetization_and_version_3_reads_none() {
    let mut k = *FaultVector::NOMINAL.as_array();
    k[0] = 0.1;
    k[8] = 0.3;
    let std = [0.01, 0.01, 0.01, 0.01, 0.01, 0.01, f32::NAN, 0.01, 0.02];
    let r = HealthRecord::new(12, FaultVector::new(k).unwrap(), 0.01, Domain::Within).with_std(std);
    assert_eq!(r.detected, 0b1_0000_0001);
    assert_eq!(HealthRecord::decode(&r.encode()), Ok(r));
    assert_eq!(r.std.get(8), Some(1311.0 / 65_536.0));
    // What a controller before version 4 kept: eight components, no demagnetization.
    let v3 = r.encode_v3();
    assert_eq!((v3.len(), v3[4], v3[7]), (RECORD_V3_BYTES, 3, 0));
    let old = HealthRecord::decode(&v3).unwrap();
    assert_eq!(old.faults.demagnetization(), 0.0);
    assert_eq!(old.faults.as_array()[..8], r.faults.as_array()[..8]);
    assert_eq!((old.std.get(8), old.std.get(0)), (None, r.std.get(0)));
    assert_eq!(old.detected, 0b1);
    // Byte 7 of an older version was reserved: a bit there is damage, not a ninth fault.
    assert_eq!(
        HealthRecord::decode(&forged(v3, 7, 1)),
        Err(HealthRecordError::BadField)
    );
    // In version 4 it holds one detected bit; the rest and bytes 78..80 stay 0.
    let v4 = r.encode_v4();
    assert_eq!(v4[7], 1);
    for (at, value) in [(7, 2), (78, 1), (79, 0x80)] {
        assert_eq!(
            HealthRecord::decode(&forged(v4, at, value)),
            Err(HealthRecordError::BadField),
            "byte {at}"
        );
    }
    // A demagnetization beyond [0, 1] is refused as any other component.
    let mut beyond = v4;
    beyond[72..76].copy_from_slice(&1.5f32.to_le_bytes());
    let beyond = forged(beyond, 0, b'E');
    assert_eq!(
        HealthRecord::decode(&beyond),
        Err(HealthRecordError::BadField)
    );
}

#[test]
fn version_3_keeps_the_day() {
    let day = RecordedDay::new(Some(271.337), Some(-40.004), Some(-58.5));
    assert_eq!(day.bus_voltage(), Some(27_134.0 * 0.01));
    assert_eq!(day.temperature(), Some(-4_000.0 * 0.01));
    assert_eq!(day.winding_rise(), Some(-5_850.0 * 0.01));
    let r = record(3, 0.2).with_day(day);
    assert_eq!(HealthRecord::decode(&r.encode()), Ok(r));
    let none = RecordedDay::new(None, Some(f32::NAN), Some(400.0));
    assert_eq!(none, RecordedDay::UNKNOWN);
    assert_eq!(
        (none.bus_voltage(), none.temperature(), none.winding_rise()),
        (None, None, None)
    );
    // Byte 71 must stay 0 on a window's own entry (CRC made good again); byte 70 is the
    // window now.
    let mut b = r.in_flight(2).encode();
    b[71] = 1;
    let mut crc = Crc32::new();
    crc.update(&b[..RECORD_BYTES - 4]);
    b[RECORD_BYTES - 4..].copy_from_slice(&crc.finish().to_le_bytes());
    assert_eq!(HealthRecord::decode(&b), Err(HealthRecordError::BadField));
}

#[test]
fn older_stores_are_upgraded_in_place() {
    for (old_bytes, encode) in [
        (
            RECORD_V1_BYTES,
            (|r: &HealthRecord| r.encode_v1().to_vec()) as fn(&HealthRecord) -> Vec<u8>,
        ),
        (RECORD_V2_BYTES, |r: &HealthRecord| r.encode_v2().to_vec()),
        (RECORD_V3_BYTES, |r: &HealthRecord| r.encode_v3().to_vec()),
    ] {
        let mut store = RamStore::<4>::ZEROED;
        let image = store.as_bytes_mut();
        image.fill(0xFF);
        // Flights 4..7 in slots 0..3 as an older controller kept them; slot 2 torn.
        for f in 4..8u32 {
            let s = (f % 4) as usize * old_bytes;
            image[s..s + old_bytes].copy_from_slice(&encode(&record(f, 0.1 * f as f32)));
        }
        image[2 * old_bytes + 30] ^= 1;
        assert_eq!(store.upgrade(old_bytes), 3, "{old_bytes}");
        let (log, summary) = HealthLog::<4>::load(&mut store).unwrap();
        assert_eq!(log.iter().map(|r| r.flight).collect::<Vec<_>>(), [4, 5, 7]);
        assert_eq!(log.latest(), Some(&record(7, 0.7)));
        assert_eq!((summary.records, summary.empty, summary.damaged), (3, 1, 0));
    }
    // A slot size of no version keeps nothing.
    assert_eq!(RamStore::<4>::erased().upgrade(60), 0);
}

#[test]
fn an_older_image_read_into_a_store_is_upgraded_by_its_length() {
    let mut store = RamStore::<4>::erased();
    for f in 0..3u32 {
        let at = f as usize * RECORD_V3_BYTES;
        store.as_bytes_mut()[at..at + RECORD_V3_BYTES].copy_from_slice(&record(f, 0.1).encode_v3());
    }
    assert_eq!(
        store.upgrade_read(4 * RECORD_V3_BYTES),
        Some((RECORD_V3_BYTES, 3))
    );
    let (log, summary) = HealthLog::<4>::load(&mut store).unwrap();
    assert_eq!(log.iter().map(|r| r.flight).collect::<Vec<_>>(), [0, 1, 2]);
    assert_eq!((summary.records, summary.damaged), (3, 0));
    // The current image, or a length of no version: nothing done.
    let before = store.clone();
    assert_eq!(store.upgrade_read(4 * RECORD_BYTES), None);
    assert_eq!(store.upgrade_read(100), None);
    assert_eq!(store, before);
}

#[test]
fn ring_hands_back_the_oldest_and_refuses_the_past() {
    let mut log = HealthLog::<3>::new();
    for f in 0..3 {
        assert_eq!(log.push(record(f, 0.1)), Ok(None));
    }
    assert_eq!(log.push(record(3, 0.1)), Ok(Some(record(0, 0.1))));
    assert_eq!(log.iter().map(|r| r.flight).collect::<Vec<_>>(), [1, 2, 3]);
    let stale = record(3, 0.2);
    assert_eq!(log.push(stale), Err(stale));
    assert_eq!(
        log.append(&mut RamStore::<3>::erased(), stale),
        Err(HealthLogError::NotNewer { last: 3 })
    );
}

#[test]
fn store_keeps_the_newest_slots_and_skips_damage() {
    let mut store = RamStore::<4>::erased();
    let mut log = HealthLog::<4>::new();
    for f in 10..17 {
        log.append(&mut store, record(f, f as f32 / 100.0)).unwrap();
    }
    // Each record in the slot after the one before: slots hold flights 14, 15, 16, 13;
    // damage the one of flight 14.
    let (loaded, summary) = HealthLog::<4>::load(&mut store.clone()).unwrap();
    assert_eq!(
        loaded.iter().map(|r| r.flight).collect::<Vec<_>>(),
        [13, 14, 15, 16]
    );
    assert_eq!(summary.records, 4);
    let mut image = store.as_bytes().to_vec();
    image[20] ^= 1;
    let (loaded, summary) = HealthLog::<3>::load(&mut RamStore::<4>::from_image(&image)).unwrap();
    assert_eq!(
        loaded.iter().map(|r| r.flight).collect::<Vec<_>>(),
        [13, 15, 16]
    );
    assert_eq!((summary.records, summary.damaged, summary.empty), (3, 1, 0));
    // A smaller log keeps the newest.
    let (small, summary) = HealthLog::<2>::load(&mut store).unwrap();
    assert_eq!(small.iter().map(|r| r.flight).collect::<Vec<_>>(), [15, 16]);
    assert_eq!(summary.dropped, 2);
    let (empty, summary) = HealthLog::<4>::load(&mut RamStore::<5>::erased()).unwrap();
    assert!(empty.is_empty());
    assert_eq!(summary.empty, 5);
}

/// A store kept one preflight per flight at slot `flight mod slots` (every log written before
/// flights' readings were logged) is the same ring: it reads unchanged, and the next record
/// goes to the slot after its newest, the oldest's, whatever the flight index.
#[test]
fn a_store_of_one_preflight_per_flight_goes_on_as_a_ring() {
    let mut store = RamStore::<4>::erased();
    for f in 10..16u32 {
        store
            .write(f as usize % 4, &record(f, 0.1).encode())
            .unwrap();
    }
    let (log, _) = HealthLog::<4>::load(&mut store).unwrap();
    assert_eq!(
        log.iter().map(|r| r.flight).collect::<Vec<_>>(),
        [12, 13, 14, 15]
    );
    // Flight 15 sits in slot 3; a reading of flight 15 takes slot 0 (flight 12's), then
    // flight 21's preflight slot 1 (flight 13's), not slot 21 mod 4.
    let written = write_slot(&mut store, &record(15, 0.2).flight_reading(3)).unwrap();
    assert_eq!(written.slot, 0);
    assert_eq!(written.replaced.map(|r| r.flight), Some(12));
    let written = write_slot(&mut store, &record(21, 0.2)).unwrap();
    assert_eq!(written.slot, 1);
    let (log, _) = HealthLog::<4>::load(&mut store).unwrap();
    assert_eq!(
        log.iter().map(|r| (r.flight, r.window)).collect::<Vec<_>>(),
        [(14, 0), (15, 0), (15, FLIGHT_READING), (21, 0)]
    );
}

/// A flight's reading as the log keeps it: its vector and deviations, the mean fitness of
/// the windows that entered it, the first's day, the windows fused, and its verdict as the
/// domain (a reading the turbulence kept loose is not trusted).
#[test]
fn a_flights_reading_is_logged_as_an_in_flight_entry() {
    use crate::flight::fusion::FlightReading;
    use crate::flight::window::WindowReason;
    use crate::solver::uncertainty::Uncertainty;
    let mut k = *FaultVector::NOMINAL.as_array();
    k[0] = 0.25;
    let reading = FlightReading {
        faults: FaultVector::new(k).unwrap(),
        uncertainty: (
            Uncertainty {
                std: [0.02; FAULT_COUNT],
                lower: [0.0; FAULT_COUNT],
                upper: [1.0; FAULT_COUNT],
                worst_correlation: 0.0,
                worst_pair: (0, 0),
                residual_std: 0.0,
                magnet_std: f32::NAN,
            },
            [[0.0; FAULT_COUNT]; FAULT_COUNT],
        ),
        windows: 7,
        shared_std: [0.0; FAULT_COUNT],
        verdict: Ok(()),
        friction_held: false,
    };
    let day = RecordedDay::new(Some(271.0), Some(5.0), None);
    let held = WeakMagnet::new(0.4, 1.0);
    let r = HealthRecord::of_flight_reading(12, &reading, 0.006, 3, day, &held);
    assert_eq!((r.flight, r.window, r.fused), (12, FLIGHT_READING, 7));
    assert_eq!(r.magnet, RecordedMagnet::of(&held));
    assert!(!r.magnet.magnets().is_none());
    assert_eq!(r.faults, reading.faults);
    assert_eq!(r.fitness, 0.002);
    assert_eq!(r.day, day);
    assert!(r.is_trusted() && !r.is_window());
    assert!((r.std.get(0).unwrap() - 0.02).abs() < 1e-4);
    let loose = FlightReading {
        verdict: Err(WindowReason::TurbulenceTooHigh { friction_std: 0.05 }),
        ..reading
    };
    assert!(!HealthRecord::of_flight_reading(12, &loose, 0.006, 3, day, &held).is_trusted());
    // No window entered: the fitness is the sum's, not a division by zero.
    assert_eq!(
        HealthRecord::of_flight_reading(12, &reading, 0.0, 0, day, &held).fitness,
        0.0
    );
}
