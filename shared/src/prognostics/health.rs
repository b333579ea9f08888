//! The actuator's health log: one fixed-size, versioned, checksummed [`HealthRecord`] per
//! preflight test and per flight's reading from its windows, kept in a bounded ring
//! ([`HealthLog`]) and persisted slot by slot in a [`HealthStore`] (RAM under emulation: [`RamStore`]; a file on the host). On the board the
//! [`RamStore`]'s whole image is kept in flash as the newest item of an A/B pair of sectors
//! (`firmware::storage::AbStore`): loaded before the health step, written back after it.
//!
//! Units: flight index (count), fault vector (normalised, [`FaultVector`]), fitness [A²·s].
//! Work bounds: [`HealthRecord::encode`]/[`HealthRecord::decode`] O([`RECORD_BYTES`]);
//! [`HealthLog::push`] O(1); [`HealthLog::append`] one survey of the store and one slot
//! write; [`HealthLog::load`] reads every slot twice (find the newest, then walk the ring
//! from it), O(slots); so do [`survey`] and [`replay`], which walk the store in order without
//! a copy of the log.
//!
//! **Order and slots.** Records are ordered by flight, then by test ([`HealthRecord::order`]:
//! a flight's preflight before its windows and its reading). A record is written to the slot
//! after the newest record's (slot 0 in an empty store), so the store is a ring in that order
//! and a full store gives up its oldest record. A log kept one preflight per flight at slot
//! `flight mod slots` (before flights' readings were logged) is the same ring and reads
//! unchanged.
//!
//! ## Record (version 6: 84 bytes, little-endian)
//!
//! | bytes | field |
//! | --- | --- |
//! | 0..4 | magic `EMAH` |
//! | 4 | version (6) |
//! | 5 | domain: 0 within, 1 no motion, 2 open phase, 3 command mismatch, 4 fitness floor, 5 segment carried nothing, 6 bus out of range, 7 temperature out of range, …, 17–19 a window of flight's own (current saturated, manoeuvre too large, play unseen) ([`DomainCode`]) |
//! | 6..8 | detected faults (u16): bit i set when component i is beyond the detection threshold (bits 0–8); bits 9–15: the weak magnet's depth's standard deviation in 512ths of its flux, rounded up (1–127; 0: not determined, or no magnet) |
//! | 8..12 | flight index (u32) |
//! | 12..44 | the paper's eight components k1 … k8, 8 × f32 |
//! | 44..48 | best fitness (f32) |
//! | 48..64 | standard deviation of k1 … k8 ([`crate::solver::uncertainty`]), 8 × u16 in units of 2⁻¹⁶; `ffff`: not determined |
//! | 64..66 | the DC bus the controller measured over the test (u16, units of 0.01 V); `ffff`: not measured |
//! | 66..68 | the temperature it measured (i16, units of 0.01 °C); `8000`: not measured |
//! | 68..70 | the winding's estimated rise from the calibration's temperature (i16, units of 0.01 K); `8000`: not estimated |
//! | 70 | the test: 0 the preflight of flight `flight`; 1 ≤ n ≤ 254 the n-th window identified in that flight; 255 ([`FLIGHT_READING`]) the flight's reading from its windows ([`HealthRecord::window`]) |
//! | 71 | a flight's reading: the windows fused into it ([`HealthRecord::fused`]); a preflight: the tests averaged into it where its noise called for more than one (`crate::prognostics::repeat`; 0: one test); a window's own entry: 0 |
//! | 72..76 | k9, demagnetization (f32) |
//! | 76..78 | its standard deviation (u16, as above) |
//! | 78 | the weak magnet the test read ([`RecordedMagnet`]; for a window's entry and a flight's reading, the preflight's that the windows held): its depth in 255ths of its flux; 0: none |
//! | 79 | its centre in 256ths of a revolution from the encoder's zero |
//! | 80..84 | CRC-32 of bytes 0..80 |
//!
//! Each older version is a prefix of this layout with its own CRC-32, and is still read
//! ([`HealthRecord::decode`] takes any; [`RamStore::upgrade`] rewrites a store of older slots
//! as the current version in place). Version 5 is the same 84 bytes with bits 9–15 zero: its
//! weak magnet reads without a deviation; version 4 also has bytes 78–79 zero: it reads as no
//! weak magnet. A reader of an older version refuses a newer record. Versions
//! 1–3 carry eight components (k9 reads 0: no demagnetization, its
//! standard deviation not determined) and byte 7 is 0: version 3 (76 bytes: bytes 0..72,
//! then their CRC-32); version 2 (68 bytes: bytes 0..64, then their CRC-32) carries no day;
//! version 1 (52 bytes: bytes 0..48, then their CRC-32) no standard deviation either.
//! Byte 70 was reserved (0) in every record written before in-flight entries: every such
//! record reads as a preflight; a reader from before refuses an in-flight entry as a bad
//! field rather than take it for a preflight. Byte 71 was reserved (0) before flights'
//! readings: a reader from before them refuses one as a bad field rather than take it for a
//! window, and a reader from before repeated tests refuses a preflight of several tests so.
//!
//! ## Slots
//!
//! A record goes to the slot after the newest record's: a store of `S` slots keeps the last
//! `S` records (preflights and flights' readings), a torn or erased slot costs that one
//! record (its checksum fails, it is skipped at load), and no head pointer has to be
//! persisted (the newest record is found by its order, [`HealthRecord::order`]).
//!

use heapless::Deque;

use crate::flight::window::WindowReason;
use crate::model::conditions::{TestConditions, WindingEstimate};
use crate::model::domain::{Domain, OutsideReason};
use crate::physics::fault::{
    FaultVector, Verdict, DEMAGNETIZATION_INDEX, FAULT_COUNT, PAPER_FAULT_COUNT,
};
use crate::physics::magnets::WeakMagnet;
use crate::test::trace::Crc32;

mod magnet;
pub use magnet::RecordedMagnet;

/// Bytes of one encoded record (versions 4 and 5), and of one store slot.
pub const RECORD_BYTES: usize = 84;

/// Bytes of a version-3 record (eight components).
pub const RECORD_V3_BYTES: usize = 76;

/// Bytes of a version-2 record (no day).
pub const RECORD_V2_BYTES: usize = 68;

/// Bytes of a version-1 record (no standard deviations).
pub const RECORD_V1_BYTES: usize = 52;

/// The record format's magic and version.
pub const RECORD_MAGIC: [u8; 4] = *b"EMAH";
pub const RECORD_VERSION: u8 = 6;

/// Bytes of a record of `version` (the byte after the magic), if it is one this code reads.
pub fn record_len(version: u8) -> Option<usize> {
    match version {
        1 => Some(RECORD_V1_BYTES),
        2 => Some(RECORD_V2_BYTES),
        3 => Some(RECORD_V3_BYTES),
        4 | 5 | RECORD_VERSION => Some(RECORD_BYTES),
        _ => None,
    }
}

/// A standard deviation as stored: units of 2⁻¹⁶ of the fault vector's range, `u16::MAX` for
/// "not determined". Largest storable: 65 534 · 2⁻¹⁶ ≈ 0.99997.
const STD_UNIT: f32 = 1.0 / 65_536.0;

/// Records the controller keeps (its log and its store).
pub const ONBOARD_RECORDS: usize = 32;

/// One encoded record.
pub type EncodedRecord = [u8; RECORD_BYTES];

/// One test's outcome as the log keeps it: a preflight, or a window of flight identified in
/// flight ([`Self::window`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthRecord {
    /// Index of the flight whose preflight (or window, or reading) this was.
    pub flight: u32,
    /// The identified fault vector.
    pub faults: FaultVector,
    /// Best fitness of the identification [A²·s].
    pub fitness: f32,
    /// The domain verdict; only tests [`Domain::Within`] feed a trend.
    pub domain: DomainCode,
    /// Bit i set: component i was beyond the detection threshold.
    pub detected: u16,
    /// The identification's standard deviation per component, as stored.
    pub std: ComponentStd,
    /// What the controller measured and estimated of the test's day, as stored.
    pub day: RecordedDay,
    /// 0: the preflight of flight `flight`; n ≥ 1: the n-th window of that flight identified
    /// in flight (an in-flight entry). The onboard log and store keep preflights and flights'
    /// readings ([`HealthLog::append`]). [`FLIGHT_READING`]: the flight's reading from its windows
    /// ([`crate::flight::fusion`]). Trends take preflights and flights' readings, each at its flight
    /// ([`crate::prognostics::prognosis::FaultTrend::add`]); a window's own entry is kept for the record,
    /// its information is in its flight's reading.
    pub window: u8,
    /// A flight's reading ([`FLIGHT_READING`]): the windows fused into it; a preflight: the
    /// tests averaged into it ([`crate::prognostics::repeat::RepeatedTests`]; 0: one test);
    /// 0 for a window's own entry.
    pub fused: u8,
    /// The weak magnet the test read, as stored ([`RecordedMagnet::NONE`]: none, or a
    /// record before version 5).
    pub magnet: RecordedMagnet,
}

/// [`HealthRecord::window`] of a flight's reading from its windows.
pub const FLIGHT_READING: u8 = u8::MAX;

/// The test's day as a record stores it: the measured bus \[V\] and temperature [°C] and the
/// winding's estimated rise from the calibration's temperature \[K\], each rounded to 0.01
/// (bus 0 … 655.34 V, the others ±327.67) or absent (not measured, or a record before
/// version 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RecordedDay {
    bus: u16,
    temperature: i16,
    winding_rise: i16,
}

impl RecordedDay {
    /// Nothing measured.
    pub const UNKNOWN: Self = Self {
        bus: u16::MAX,
        temperature: i16::MIN,
        winding_rise: i16::MIN,
    };

    /// The day rounded to what is stored; a value that is NaN or beyond the range is absent.
    pub fn new(
        bus_voltage: Option<f32>,
        temperature: Option<f32>,
        winding_rise: Option<f32>,
    ) -> Self {
        Self {
            bus: hundredths(bus_voltage, 0, 65_534).unwrap_or(u16::MAX.into()) as u16,
            temperature: hundredths(temperature, -32_767, 32_767).unwrap_or(i16::MIN.into()) as i16,
            winding_rise: hundredths(winding_rise, -32_767, 32_767).unwrap_or(i16::MIN.into())
                as i16,
        }
    }

    /// What a test's day estimate keeps: the measured bus and temperature, and the winding's
    /// rise where the injection estimated it.
    pub fn of(day: &TestConditions) -> Self {
        let estimated = matches!(day.winding, WindingEstimate::Injection);
        Self::new(
            day.bus_voltage,
            day.measured_temperature,
            estimated.then_some(day.winding_rise),
        )
    }

    /// The measured bus \[V\].
    pub fn bus_voltage(&self) -> Option<f32> {
        (self.bus != u16::MAX).then(|| f32::from(self.bus) * 0.01)
    }

    /// The measured temperature [°C].
    pub fn temperature(&self) -> Option<f32> {
        (self.temperature != i16::MIN).then(|| f32::from(self.temperature) * 0.01)
    }

    /// The winding's estimated rise from the calibration's temperature \[K\].
    pub fn winding_rise(&self) -> Option<f32> {
        (self.winding_rise != i16::MIN).then(|| f32::from(self.winding_rise) * 0.01)
    }
}

/// The identification's standard deviation of each component as a record stores it: a
/// multiple of 2⁻¹⁶ of the fault vector's range, or "not determined" (the test did not
/// determine the component, or a version-1 record).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ComponentStd([u16; FAULT_COUNT]);

impl ComponentStd {
    /// Nothing determined.
    pub const UNKNOWN: Self = Self([u16::MAX; FAULT_COUNT]);

    /// `std` rounded to what is stored (NaN or negative: not determined; beyond 0.99997:
    /// 0.99997). Out of line (flash).
    #[inline(never)]
    pub fn new(std: [f32; FAULT_COUNT]) -> Self {
        Self(std.map(|s| {
            if s.is_nan() || s < 0.0 {
                return u16::MAX;
            }
            let units = s / STD_UNIT + 0.5;
            if units >= 65_534.0 {
                65_534
            } else {
                units as u16
            }
        }))
    }

    /// Component `i`'s standard deviation, if determined.
    pub fn get(&self, i: usize) -> Option<f32> {
        match self.0.get(i) {
            Some(&c) if c != u16::MAX => Some(f32::from(c) * STD_UNIT),
            _ => None,
        }
    }

    fn codes(&self) -> [u16; FAULT_COUNT] {
        self.0
    }
}

/// `v` in hundredths, rounded half away from zero, if it is finite and within `[lo, hi]`.
/// One out-of-line copy for the three fields (flash).
#[inline(never)]
fn hundredths(v: Option<f32>, lo: i32, hi: i32) -> Option<i32> {
    let h = v? * 100.0;
    // Saturating: beyond i32 lands outside [lo, hi]; NaN gives 0, refused by the test.
    let rounded = (h + if h < 0.0 { -0.5 } else { 0.5 }) as i32;
    (!h.is_nan() && (lo..=hi).contains(&rounded)).then_some(rounded)
}

/// The domain verdict as stored (the reason without its measured value).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DomainCode {
    Within = 0,
    NoMotion = 1,
    OpenPhase = 2,
    CommandMismatch = 3,
    FitnessFloor = 4,
    SegmentCarriedNothing = 5,
    BusOutOfRange = 6,
    TemperatureOutOfRange = 7,
    EncoderStuck = 8,
    EncoderGlitch = 9,
    CurrentSenseOffset = 10,
    CurrentSenseGain = 11,
    TransducerDisagrees = 12,
    InstallationChanged = 13,
    GreaseOutOfRange = 14,
    LoadMoved = 15,
    LoadMovedAtRest = 16,
    /// A window of flight whose current reached the drive's limit ([`WindowReason`]).
    CurrentSaturated = 17,
    /// A window of flight that held a manoeuvre ([`WindowReason`]).
    ManoeuvreTooLarge = 18,
    /// A window of flight whose load never crossed the gear's play ([`WindowReason`]).
    PlayUnseen = 19,
    /// A window of flight that could not read friction for its turbulence ([`WindowReason`]).
    TurbulenceTooHigh = 20,
    /// A flight's reading that no second window confirms ([`WindowReason`]).
    Unconfirmed = 21,
}

impl From<Result<(), WindowReason>> for DomainCode {
    /// A window's verdict as stored (its fit's floor is the preflight's code).
    fn from(v: Result<(), WindowReason>) -> Self {
        match v {
            Ok(()) => Self::Within,
            Err(WindowReason::CurrentSaturated { .. }) => Self::CurrentSaturated,
            Err(WindowReason::ManoeuvreTooLarge { .. }) => Self::ManoeuvreTooLarge,
            Err(WindowReason::FitnessFloor { .. }) => Self::FitnessFloor,
            Err(WindowReason::PlayUnseen { .. }) => Self::PlayUnseen,
            Err(WindowReason::TurbulenceTooHigh { .. }) => Self::TurbulenceTooHigh,
            Err(WindowReason::Unconfirmed { .. }) => Self::Unconfirmed,
        }
    }
}

impl From<Domain> for DomainCode {
    fn from(d: Domain) -> Self {
        match d {
            Domain::Within => Self::Within,
            Domain::Outside(OutsideReason::NoMotion { .. }) => Self::NoMotion,
            Domain::Outside(OutsideReason::OpenPhase { .. }) => Self::OpenPhase,
            Domain::Outside(OutsideReason::CommandMismatch { .. }) => Self::CommandMismatch,
            Domain::Outside(OutsideReason::FitnessFloor { .. }) => Self::FitnessFloor,
            Domain::Outside(OutsideReason::SegmentCarriedNothing { .. }) => {
                Self::SegmentCarriedNothing
            }
            Domain::Outside(OutsideReason::BusOutOfRange { .. }) => Self::BusOutOfRange,
            Domain::Outside(OutsideReason::TemperatureOutOfRange { .. }) => {
                Self::TemperatureOutOfRange
            }
            Domain::Outside(OutsideReason::EncoderStuck { .. }) => Self::EncoderStuck,
            Domain::Outside(OutsideReason::EncoderGlitch { .. }) => Self::EncoderGlitch,
            Domain::Outside(OutsideReason::CurrentSenseOffset { .. }) => Self::CurrentSenseOffset,
            Domain::Outside(OutsideReason::CurrentSenseGain { .. }) => Self::CurrentSenseGain,
            Domain::Outside(OutsideReason::TransducerDisagrees { .. }) => Self::TransducerDisagrees,
            Domain::Outside(OutsideReason::InstallationChanged { .. }) => Self::InstallationChanged,
            Domain::Outside(OutsideReason::GreaseOutOfRange { .. }) => Self::GreaseOutOfRange,
            Domain::Outside(OutsideReason::LoadMoved { .. }) => Self::LoadMoved,
            Domain::Outside(OutsideReason::LoadMovedAtRest { .. }) => Self::LoadMovedAtRest,
        }
    }
}

impl DomainCode {
    /// Every code, in the order of its byte.
    const ALL: [Self; 22] = [
        Self::Within,
        Self::NoMotion,
        Self::OpenPhase,
        Self::CommandMismatch,
        Self::FitnessFloor,
        Self::SegmentCarriedNothing,
        Self::BusOutOfRange,
        Self::TemperatureOutOfRange,
        Self::EncoderStuck,
        Self::EncoderGlitch,
        Self::CurrentSenseOffset,
        Self::CurrentSenseGain,
        Self::TransducerDisagrees,
        Self::InstallationChanged,
        Self::GreaseOutOfRange,
        Self::LoadMoved,
        Self::LoadMovedAtRest,
        Self::CurrentSaturated,
        Self::ManoeuvreTooLarge,
        Self::PlayUnseen,
        Self::TurbulenceTooHigh,
        Self::Unconfirmed,
    ];

    fn from_byte(b: u8) -> Option<Self> {
        Self::ALL.get(usize::from(b)).copied()
    }

    /// Short name for reports and CSV files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Within => "within",
            Self::NoMotion => "no_motion",
            Self::OpenPhase => "open_phase",
            Self::CommandMismatch => "command_mismatch",
            Self::FitnessFloor => "fitness_floor",
            Self::SegmentCarriedNothing => "segment_carried_nothing",
            Self::BusOutOfRange => "bus_out_of_range",
            Self::TemperatureOutOfRange => "temperature_out_of_range",
            Self::EncoderStuck => "encoder_stuck",
            Self::EncoderGlitch => "encoder_glitch",
            Self::CurrentSenseOffset => "current_sense_offset",
            Self::CurrentSenseGain => "current_sense_gain",
            Self::TransducerDisagrees => "transducer_disagrees",
            Self::InstallationChanged => "installation_changed",
            Self::GreaseOutOfRange => "grease_out_of_range",
            Self::LoadMoved => "load_moved",
            Self::LoadMovedAtRest => "load_moved_at_rest",
            Self::CurrentSaturated => "current_saturated",
            Self::ManoeuvreTooLarge => "manoeuvre_too_large",
            Self::PlayUnseen => "play_unseen",
            Self::TurbulenceTooHigh => "turbulence_too_high",
            Self::Unconfirmed => "unconfirmed",
        }
    }

    /// Inverse of [`DomainCode::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// Why bytes are not a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HealthRecordError {
    /// Not a record (an erased or never-written slot reads this way).
    BadMagic,
    /// A version this code does not know (it reads 1 and 2).
    UnsupportedVersion(u8),
    BadChecksum,
    /// Sound checksum but a field out of its domain (a forged or buggy writer).
    BadField,
}

impl HealthRecord {
    /// Every byte zero: a buffer's idle state, not a reading (its bus, temperature and
    /// deviations read 0, not "unknown").
    pub(crate) const ZEROED: Self = Self {
        flight: 0,
        faults: FaultVector::ZEROED,
        fitness: 0.0,
        domain: DomainCode::Within,
        detected: 0,
        std: ComponentStd([0; FAULT_COUNT]),
        day: RecordedDay {
            bus: 0,
            temperature: 0,
            winding_rise: 0,
        },
        window: 0,
        fused: 0,
        magnet: RecordedMagnet::NONE,
    };

    /// The record of one preflight: `detected` follows from the fault vector; no standard
    /// deviation (see [`Self::with_std`]). Out of line: the controller builds records in
    /// several places (flash).
    #[inline(never)]
    pub fn new(flight: u32, faults: FaultVector, fitness: f32, domain: Domain) -> Self {
        let mut detected = 0u16;
        for (i, v) in faults.verdicts().iter().enumerate() {
            if *v == Verdict::Faulty {
                detected |= 1 << i;
            }
        }
        Self {
            flight,
            faults,
            fitness,
            domain: domain.into(),
            detected,
            std: ComponentStd::UNKNOWN,
            day: RecordedDay::UNKNOWN,
            window: 0,
            fused: 0,
            magnet: RecordedMagnet::NONE,
        }
    }

    /// The same record with the weak magnet its test read.
    #[must_use]
    pub fn with_magnet(mut self, magnets: &WeakMagnet) -> Self {
        self.magnet = RecordedMagnet::of(magnets);
        self
    }

    /// The same record with its weak magnet's depth's standard deviation
    /// ([`RecordedMagnet::with_std`]; nothing without a magnet).
    #[must_use]
    pub fn with_magnet_std(mut self, std: f32) -> Self {
        self.magnet = self.magnet.with_std(std);
        self
    }

    /// Where the record sits in a log: by flight, then by test (the preflight, its windows in
    /// turn, then the flight's reading). Strictly increasing in a log and a store. O(1).
    pub fn order(&self) -> u64 {
        (u64::from(self.flight) << 8) | u64::from(self.window)
    }

    /// The record as the `window`-th window of its flight identified in flight (0: the
    /// preflight).
    pub fn in_flight(mut self, window: u8) -> Self {
        self.window = window;
        self
    }

    /// The record as its flight's reading from `fused` windows ([`FLIGHT_READING`]).
    pub fn flight_reading(mut self, fused: u8) -> Self {
        self.window = FLIGHT_READING;
        self.fused = fused;
        self
    }

    /// The record of flight `flight`'s reading from its windows (`reading`,
    /// [`crate::flight::fusion::WindowFusion::final_reading`]): its vector, deviations and
    /// verdict, as a [`FLIGHT_READING`] entry of `reading.windows` windows; its fitness the
    /// mean of the `entered` windows' (`fitness_sum` their sum, in the order they entered),
    /// its day the first entered window's; its weak magnet `held`, the preflight's that the
    /// windows held. The host's and the controller's entry alike. O(1).
    pub fn of_flight_reading(
        flight: u32,
        reading: &crate::flight::fusion::FlightReading,
        fitness_sum: f32,
        entered: u32,
        day: RecordedDay,
        held: &WeakMagnet,
    ) -> Self {
        let fitness = fitness_sum / entered.max(1) as f32;
        let mut record = Self::new(flight, reading.faults, fitness, Domain::Within)
            .with_std(reading.uncertainty.0.std)
            .with_day(day)
            .with_magnet(held)
            .flight_reading(u8::try_from(reading.windows).unwrap_or(u8::MAX));
        record.domain = reading.verdict.into();
        record
    }

    /// The record with the test's day (see [`RecordedDay::new`]).
    pub fn with_day(mut self, day: RecordedDay) -> Self {
        self.day = day;
        self
    }

    /// The record with the identification's standard deviations (see [`ComponentStd::new`]).
    pub fn with_std(mut self, std: [f32; FAULT_COUNT]) -> Self {
        self.std = ComponentStd::new(std);
        self
    }

    /// Whether this is one window's own entry (1 ≤ [`Self::window`] < [`FLIGHT_READING`]):
    /// kept for the record, not trended (its information is in its flight's reading).
    pub fn is_window(&self) -> bool {
        self.window != 0 && self.window != FLIGHT_READING
    }

    /// Whether this test can feed a trend (inside the monitor model's domain).
    pub fn is_trusted(&self) -> bool {
        self.domain == DomainCode::Within
    }

    pub fn encode(&self) -> EncodedRecord {
        let mut out = [0u8; RECORD_BYTES];
        let mut w = Writer {
            out: &mut out,
            at: 0,
        };
        w.put(&RECORD_MAGIC);
        w.put(&[RECORD_VERSION, self.domain as u8]);
        // Byte 7: the detected bit of k9, then the weak magnet's deviation.
        let [detected, detected_high] = self.detected.to_le_bytes();
        w.put(&[detected, (detected_high & 1) | (self.magnet.std << 1)]);
        w.put(&self.flight.to_le_bytes());
        let (paper, ninth) = self.faults.as_array().split_at(PAPER_FAULT_COUNT);
        for k in paper {
            w.put(&k.to_le_bytes());
        }
        w.put(&self.fitness.to_le_bytes());
        let codes = self.std.codes();
        let (paper_std, ninth_std) = codes.split_at(PAPER_FAULT_COUNT);
        for c in paper_std {
            w.put(&c.to_le_bytes());
        }
        w.put(&self.day.bus.to_le_bytes());
        w.put(&self.day.temperature.to_le_bytes());
        w.put(&self.day.winding_rise.to_le_bytes());
        w.put(&[self.window, self.fused]);
        for k in ninth {
            w.put(&k.to_le_bytes());
        }
        for c in ninth_std {
            w.put(&c.to_le_bytes());
        }
        w.put(&[self.magnet.depth, self.magnet.centre]);
        let mut crc = Crc32::new();
        crc.update(w.out.get(..RECORD_BYTES - 4).unwrap_or(&[]));
        let sum = crc.finish().to_le_bytes();
        w.put(&sum);
        out
    }

    /// The record in `bytes`: version 6 ([`RECORD_BYTES`]), version 5 (the same bytes, no
    /// weak magnet's deviation), version 4 (no weak magnet), version 3 ([`RECORD_V3_BYTES`];
    /// eight components, no demagnetization), version 2 ([`RECORD_V2_BYTES`]; no day either)
    /// or version 1 ([`RECORD_V1_BYTES`]; no standard deviation either). Bytes beyond the
    /// record are ignored.
    pub fn decode(bytes: &[u8]) -> Result<Self, HealthRecordError> {
        let word = |at: usize| -> [u8; 4] {
            let mut w = [0u8; 4];
            if let Some(src) = bytes.get(at..at + 4) {
                w.copy_from_slice(src);
            }
            w
        };
        if word(0) != RECORD_MAGIC {
            return Err(HealthRecordError::BadMagic);
        }
        let [version, domain, detected, detected_high] = word(4);
        let Some(len) = record_len(version) else {
            return Err(HealthRecordError::UnsupportedVersion(version));
        };
        let (Some(body), Some(sum)) = (bytes.get(..len - 4), bytes.get(len - 4..len)) else {
            return Err(HealthRecordError::BadChecksum);
        };
        let mut crc = Crc32::new();
        crc.update(body);
        if crc.finish().to_le_bytes() != *sum {
            return Err(HealthRecordError::BadChecksum);
        }
        let ninth = version >= 4;
        // k1 … k8 at 12..44, k9 at 72 (a record before version 4: no demagnetization).
        let mut k = *FaultVector::NOMINAL.as_array();
        for (i, v) in k.iter_mut().enumerate().take(PAPER_FAULT_COUNT) {
            *v = f32::from_le_bytes(word(12 + 4 * i));
        }
        if let (true, Some(v)) = (ninth, k.get_mut(DEMAGNETIZATION_INDEX)) {
            *v = f32::from_le_bytes(word(72));
        }
        let fitness = f32::from_le_bytes(word(44));
        let half = |at: usize| match bytes.get(at..at + 2) {
            Some(&[lo, hi]) => [lo, hi],
            _ => [0; 2],
        };
        let mut std = ComponentStd::UNKNOWN;
        if version >= 2 {
            for (i, c) in std.0.iter_mut().enumerate().take(PAPER_FAULT_COUNT) {
                *c = u16::from_le_bytes(half(48 + 2 * i));
            }
        }
        if let (true, Some(c)) = (ninth, std.0.get_mut(DEMAGNETIZATION_INDEX)) {
            *c = u16::from_le_bytes(half(76));
        }
        // Byte 70 is the window (reserved, 0, before in-flight entries), byte 71 the windows
        // a flight's reading fused (reserved, 0, before them; 0 for any other test).
        let (day, window_reserved) = if version >= 3 {
            let day = RecordedDay {
                bus: u16::from_le_bytes(half(64)),
                temperature: i16::from_le_bytes(half(66)),
                winding_rise: i16::from_le_bytes(half(68)),
            };
            (day, u16::from_le_bytes(half(70)))
        } else {
            (RecordedDay::UNKNOWN, 0)
        };
        // Byte 7 was reserved before version 4; now it holds the detected bits past eight,
        // and from version 6 the weak magnet's deviation above them.
        // Bytes 78–79 were reserved in version 4; version 5 keeps the weak magnet there.
        let [magnet_depth, magnet_centre] = half(78);
        let (reserved, magnet) = match version {
            6.. => (
                0,
                RecordedMagnet {
                    depth: magnet_depth,
                    centre: magnet_centre,
                    std: detected_high >> 1,
                },
            ),
            5 => (
                u16::from(detected_high >> 1),
                RecordedMagnet {
                    depth: magnet_depth,
                    centre: magnet_centre,
                    std: 0,
                },
            ),
            4 => (
                u16::from_le_bytes([magnet_depth, magnet_centre]) | u16::from(detected_high >> 1),
                RecordedMagnet::NONE,
            ),
            _ => (u16::from(detected_high), RecordedMagnet::NONE),
        };
        // No magnet read: its centre and its deviation are 0.
        let centre_reserved =
            magnet_depth == 0 && version >= 5 && (magnet_centre != 0 || magnet.std != 0);
        match (
            DomainCode::from_byte(domain),
            FaultVector::new(k),
            (
                reserved,
                // Byte 71: a flight's reading's windows, a preflight's tests averaged (0 or 1:
                // one), never a window's own entry's.
                matches!(window_reserved as u8, 0 | FLIGHT_READING) || window_reserved >> 8 == 0,
            ),
            fitness.is_finite() && !centre_reserved,
        ) {
            (Some(domain), Ok(faults), (0, true), true) => Ok(Self {
                flight: u32::from_le_bytes(word(8)),
                faults,
                fitness,
                domain,
                detected: u16::from_le_bytes([detected, if ninth { detected_high & 1 } else { 0 }]),
                std,
                day,
                window: window_reserved as u8,
                fused: (window_reserved >> 8) as u8,
                magnet,
            }),
            _ => Err(HealthRecordError::BadField),
        }
    }

    /// Version-1 bytes of this record (its standard deviations and day are dropped): what a
    /// controller before version 2 wrote. For tests and tools that make old logs.
    pub fn encode_v1(&self) -> [u8; RECORD_V1_BYTES] {
        self.encode_older(1)
    }

    /// Version-2 bytes of this record (its day is dropped): what a controller before version
    /// 3 wrote. For tests and tools that make old logs.
    pub fn encode_v2(&self) -> [u8; RECORD_V2_BYTES] {
        self.encode_older(2)
    }

    /// Version-3 bytes of this record (its demagnetization is dropped): what a controller
    /// before version 4 wrote. For tests and tools that make old logs.
    pub fn encode_v3(&self) -> [u8; RECORD_V3_BYTES] {
        self.encode_older(3)
    }

    /// Version-4 bytes of this record (its weak magnet is dropped): what a controller before
    /// version 5 wrote. For tests and tools that make old logs.
    pub fn encode_v4(&self) -> EncodedRecord {
        Self {
            magnet: RecordedMagnet::NONE,
            ..*self
        }
        .encode_older(4)
    }

    /// Version-5 bytes of this record (its weak magnet's deviation is dropped): what a
    /// controller before version 6 wrote. For tests and tools that make old logs.
    pub fn encode_v5(&self) -> EncodedRecord {
        Self {
            magnet: self.magnet.with_std(f32::NAN),
            ..*self
        }
        .encode_older(5)
    }

    /// The first `N − 4` bytes of the current encoding as `version` (byte 7, the detected
    /// bits past eight, 0 before version 4, as it was reserved), then their CRC-32.
    fn encode_older<const N: usize>(&self, version: u8) -> [u8; N] {
        let mut out = [0u8; N];
        let current = self.encode();
        if let (Some(dst), Some(src)) = (out.get_mut(..N - 4), current.get(..N - 4)) {
            dst.copy_from_slice(src);
        }
        if let Some(v) = out.get_mut(4) {
            *v = version;
        }
        if version < 4 {
            if let Some(v) = out.get_mut(7) {
                *v = 0;
            }
        }
        let mut crc = Crc32::new();
        crc.update(out.get(..N - 4).unwrap_or(&[]));
        let sum = crc.finish().to_le_bytes();
        if let Some(dst) = out.get_mut(N - 4..) {
            dst.copy_from_slice(&sum);
        }
        out
    }
}

struct Writer<'a> {
    out: &'a mut EncodedRecord,
    at: usize,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        self.at += bytes.len();
    }
}

/// Persistent slots of [`RECORD_BYTES`] each (a store of version-1 slots reads its 52 bytes
/// into the start of `out`). `read` of a never-written slot returns whatever
/// the medium holds (erased flash: 0xFF); decoding tells records from the rest.
pub trait HealthStore {
    type Error;
    /// Number of slots (constant for a store).
    fn slots(&self) -> usize;
    fn read(&mut self, slot: usize, out: &mut EncodedRecord) -> Result<(), Self::Error>;
    fn write(&mut self, slot: usize, record: &EncodedRecord) -> Result<(), Self::Error>;
}

/// A store in RAM: the controller under emulation (its image is saved to and loaded from a
/// semihosting file between runs), and tests.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RamStore<const S: usize> {
    slots: [EncodedRecord; S],
}

/// A slot index beyond the store.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NoSuchSlot(pub usize);

impl<const S: usize> RamStore<S> {
    /// Bytes of the whole image (`S · RECORD_BYTES`).
    pub const IMAGE_BYTES: usize = S * RECORD_BYTES;

    /// Every byte zero (not a valid erased sector): a `static` holding it lives in `.bss`
    /// and is built in place; [`erase`](Self::erase) it before use.
    pub const ZEROED: Self = Self {
        slots: [[0; RECORD_BYTES]; S],
    };

    /// Erases every slot in place (every byte 0xFF). O(`S · 84`).
    pub fn erase(&mut self) {
        self.as_bytes_mut().fill(0xFF);
    }

    /// Rewrites, in place, an image whose first `S · old_bytes` bytes are `S` slots of an
    /// older version ([`RECORD_V1_BYTES`], [`RECORD_V2_BYTES`] or [`RECORD_V3_BYTES`]: what
    /// a controller before version 4 kept) as `S` current slots (see [`upgrade_image`]).
    /// Returns the records kept. O(`S · 84`).
    pub fn upgrade(&mut self, old_bytes: usize) -> usize {
        upgrade_image(self.as_bytes_mut(), S, old_bytes)
    }

    /// After `len` bytes of a stored image were read into the start of this store: when `len`
    /// is an older version's whole image (`S` slots of 52, 68 or 76 bytes), upgrades it in
    /// place and returns that slot size and the records kept; `None` for anything else (the
    /// current image, or nothing to upgrade). What a controller does with the image its flash
    /// or file kept. O(`S · 84`).
    pub fn upgrade_read(&mut self, len: usize) -> Option<(usize, usize)> {
        // The three older sizes written out: through `record_len` the board image grows 64 B
        // (it has none to spare).
        let old = [RECORD_V1_BYTES, RECORD_V2_BYTES, RECORD_V3_BYTES]
            .into_iter()
            .find(|&old| len == S * old)?;
        Some((old, self.upgrade(old)))
    }

    /// An erased store (every byte 0xFF, as flash after erase).
    pub const fn erased() -> Self {
        Self {
            slots: [[0xFF; RECORD_BYTES]; S],
        }
    }

    /// The store from an image: slot `i` is bytes `84·i..84·(i+1)`; a short image leaves the
    /// remaining slots erased, bytes beyond `IMAGE_BYTES` are ignored.
    pub fn from_image(image: &[u8]) -> Self {
        let mut store = Self::erased();
        for (slot, chunk) in store.slots.iter_mut().zip(image.chunks_exact(RECORD_BYTES)) {
            slot.copy_from_slice(chunk);
        }
        store
    }

    /// The image: slot after slot.
    pub fn as_bytes(&self) -> &[u8] {
        self.slots.as_flattened()
    }

    /// The image, writable (to load it from where it was kept).
    pub fn as_bytes_mut(&mut self) -> &mut [u8] {
        self.slots.as_flattened_mut()
    }
}

impl<const S: usize> HealthStore for RamStore<S> {
    type Error = NoSuchSlot;

    fn slots(&self) -> usize {
        S
    }

    fn read(&mut self, slot: usize, out: &mut EncodedRecord) -> Result<(), NoSuchSlot> {
        *out = *self.slots.get(slot).ok_or(NoSuchSlot(slot))?;
        Ok(())
    }

    fn write(&mut self, slot: usize, record: &EncodedRecord) -> Result<(), NoSuchSlot> {
        *self.slots.get_mut(slot).ok_or(NoSuchSlot(slot))? = *record;
        Ok(())
    }
}

/// Why a record was not added to the log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HealthLogError<E> {
    /// It does not come after the newest record ([`HealthRecord::order`]), of flight `last`.
    NotNewer { last: u32 },
    /// One window's own entry ([`HealthRecord::is_window`]): the onboard log and store keep
    /// preflights and flights' readings (a window's evidence is in its flight's reading).
    InFlightEntry,
    /// The store has no slot.
    NoSlots,
    /// The store failed; the log in RAM is unchanged.
    Store(E),
}

/// What [`HealthLog::load`] found in the store.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoadSummary {
    /// Sound records read.
    pub records: u16,
    /// Slots never written (or erased).
    pub empty: u16,
    /// Slots with a record that failed its checksum, version or field checks.
    pub damaged: u16,
    /// Sound records dropped: older than the log's capacity, or a repeated flight index.
    pub dropped: u16,
}

/// The newest `N` records, oldest first, strictly increasing in [`HealthRecord::order`].
#[derive(Clone, Debug)]
pub struct HealthLog<const N: usize> {
    records: Deque<HealthRecord, N>,
}

impl<const N: usize> Default for HealthLog<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> HealthLog<N> {
    pub const fn new() -> Self {
        Self {
            records: Deque::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &HealthRecord> {
        self.records.iter()
    }

    pub fn latest(&self) -> Option<&HealthRecord> {
        self.records.back()
    }

    /// Adds `record` as the newest. When the ring is full the oldest record leaves it and is
    /// handed back (`Ok(Some(oldest))`); a record not newer than the newest (or any record
    /// when `N = 0`) is handed back as the error, nothing changed. O(1).
    pub fn push(&mut self, record: HealthRecord) -> Result<Option<HealthRecord>, HealthRecord> {
        if self
            .records
            .back()
            .is_some_and(|last| record.order() <= last.order())
        {
            return Err(record);
        }
        let evicted = if self.records.is_full() {
            self.records.pop_front()
        } else {
            None
        };
        self.records.push_back(record).map(|()| evicted)
    }

    /// Writes `record` to the slot after the store's newest (see [`write_slot`]), then adds
    /// it to the log (see [`Self::push`]). Returns the record that left the ring, if any. A
    /// preflight or a flight's reading; one window's own entry is refused.
    pub fn append<S: HealthStore>(
        &mut self,
        store: &mut S,
        record: HealthRecord,
    ) -> Result<Option<HealthRecord>, HealthLogError<S::Error>> {
        if let Some(last) = self.records.back() {
            if record.order() <= last.order() {
                return Err(HealthLogError::NotNewer { last: last.flight });
            }
        }
        if N == 0 {
            return Err(HealthLogError::NoSlots);
        }
        write_slot(store, &record)?;
        // Checked above: newer than the newest, and N > 0.
        self.push(record).map_err(|_| HealthLogError::NoSlots)
    }

    /// Reads every slot of `store` and keeps the newest `N` sound records in order. Two
    /// passes over the slots, no sorting: the newest record's slot is found first, and since
    /// each record was written to the slot after the one before, walking the slots on from
    /// there meets the store's records oldest first (a record out of that order, left from
    /// an earlier lap of the ring, is dropped).
    pub fn load<S: HealthStore>(store: &mut S) -> Result<(Self, LoadSummary), S::Error> {
        let mut log = Self::new();
        let summary = log.reload(store)?;
        Ok((log, summary))
    }

    /// [`Self::load`] into this log, in place (its records are replaced).
    pub fn reload<S: HealthStore>(&mut self, store: &mut S) -> Result<LoadSummary, S::Error> {
        self.records.clear();
        let (mut summary, newest) = survey(store)?;
        if let Some(n) = newest {
            replay(store, n.slot, |r| {
                // The replay is in flight order: only the capacity can refuse.
                let _ = self.push(*r);
            })?;
        }
        summary.dropped = summary.records.saturating_sub(self.len() as u16);
        Ok(summary)
    }
}

/// The newest record of a store: its slot, flight and [`HealthRecord::order`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Newest {
    pub slot: usize,
    pub flight: u32,
    pub order: u64,
}

/// What a store's slots hold: sound, empty and damaged slots (`dropped` left 0), and the
/// newest record. One read of every slot.
pub fn survey<S: HealthStore>(store: &mut S) -> Result<(LoadSummary, Option<Newest>), S::Error> {
    let mut summary = LoadSummary::default();
    let mut bytes = [0u8; RECORD_BYTES];
    let mut newest: Option<Newest> = None;
    for slot in 0..store.slots() {
        store.read(slot, &mut bytes)?;
        match HealthRecord::decode(&bytes) {
            Ok(r) => {
                summary.records = summary.records.saturating_add(1);
                if newest.is_none_or(|n| r.order() > n.order) {
                    newest = Some(Newest {
                        slot,
                        flight: r.flight,
                        order: r.order(),
                    });
                }
            }
            Err(HealthRecordError::BadMagic) if is_blank(&bytes) => {
                summary.empty = summary.empty.saturating_add(1);
            }
            Err(_) => summary.damaged = summary.damaged.saturating_add(1),
        }
    }
    Ok((summary, newest))
}

/// Calls `each` with the store's sound records oldest first, given the newest record's slot
/// ([`survey`]): since each record was written to the slot after the one before, walking the
/// slots on from the newest meets them in order; a record out of that order (from an earlier
/// lap of the ring) is skipped. Returns the records passed. One read of every slot,
/// no copy of the log: the controller's trend replays its store this way.
pub fn replay<S: HealthStore>(
    store: &mut S,
    newest_slot: usize,
    mut each: impl FnMut(&HealthRecord),
) -> Result<u32, S::Error> {
    let mut bytes = [0u8; RECORD_BYTES];
    let slots = store.slots();
    let mut last: Option<u64> = None;
    let mut passed = 0;
    for k in 1..=slots {
        store.read((newest_slot + k) % slots, &mut bytes)?;
        if let Ok(r) = HealthRecord::decode(&bytes) {
            if last.is_none_or(|l| r.order() > l) {
                last = Some(r.order());
                passed += 1;
                each(&r);
            }
        }
    }
    Ok(passed)
}

/// Where [`write_slot`] put a record, and the sound record the slot held before.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Written {
    pub slot: usize,
    pub replaced: Option<HealthRecord>,
}

/// Writes `record` to `store`, in the slot after the newest record's (slot 0 in an empty
/// store): one survey of the store ([`survey`]), then [`write_after`].
pub fn write_slot<S: HealthStore>(
    store: &mut S,
    record: &HealthRecord,
) -> Result<Written, HealthLogError<S::Error>> {
    let (_, newest) = survey(store).map_err(HealthLogError::Store)?;
    write_after(store, record, newest)
}

/// Writes `record` to the slot after `newest` (the store's newest record, as [`survey`]
/// found it; `None`: an empty store, slot 0): one read (what the slot held) and one write. A
/// record that does not come after the newest ([`HealthRecord::order`]) is refused, and so
/// is one window's own entry ([`HealthRecord::is_window`]).
pub fn write_after<S: HealthStore>(
    store: &mut S,
    record: &HealthRecord,
    newest: Option<Newest>,
) -> Result<Written, HealthLogError<S::Error>> {
    let slots = store.slots();
    if slots == 0 {
        return Err(HealthLogError::NoSlots);
    }
    if record.is_window() {
        return Err(HealthLogError::InFlightEntry);
    }
    if let Some(n) = newest.filter(|n| record.order() <= n.order) {
        return Err(HealthLogError::NotNewer { last: n.flight });
    }
    let slot = newest.map_or(0, |n| (n.slot + 1) % slots);
    let mut bytes = [0u8; RECORD_BYTES];
    store
        .read(slot, &mut bytes)
        .map_err(HealthLogError::Store)?;
    let replaced = HealthRecord::decode(&bytes).ok();
    store
        .write(slot, &record.encode())
        .map_err(HealthLogError::Store)?;
    Ok(Written { slot, replaced })
}

/// Rewrites, in place, the first `slots · old_bytes` bytes of `image` (slots of an older
/// version: [`RECORD_V1_BYTES`], [`RECORD_V2_BYTES`] or [`RECORD_V3_BYTES`]) as `slots` current slots: each sound
/// record of that version re-encoded in its slot (what the old version lacks left unknown),
/// every other slot erased. Slots are taken last to first, so that none is overwritten
/// before it is read (a current slot starts at or after its older self). Slots beyond the
/// image are left out; `old_bytes` of no older version keeps nothing. Returns the records
/// kept. O(`slots · 84`).
pub fn upgrade_image(image: &mut [u8], slots: usize, old_bytes: usize) -> usize {
    let Some(version) = (1..RECORD_VERSION).find(|v| record_len(*v) == Some(old_bytes)) else {
        return 0;
    };
    let mut kept = 0;
    for i in (0..slots).rev() {
        let mut old = [0u8; RECORD_V3_BYTES];
        if let (Some(dst), Some(src)) = (
            old.get_mut(..old_bytes),
            image.get(i * old_bytes..(i + 1) * old_bytes),
        ) {
            dst.copy_from_slice(src);
        }
        let new = match HealthRecord::decode(&old) {
            Ok(r) if old.get(4) == Some(&version) => {
                kept += 1;
                r.encode()
            }
            _ => [0xFF; RECORD_BYTES],
        };
        if let Some(dst) = image.get_mut(i * RECORD_BYTES..(i + 1) * RECORD_BYTES) {
            dst.copy_from_slice(&new);
        }
    }
    kept
}

/// A never-written slot: all 0xFF (erased flash) or all zero (fresh RAM or file).
pub fn is_blank(bytes: &[u8]) -> bool {
    let first = bytes.first().copied().unwrap_or(0);
    (first == 0 || first == 0xFF) && bytes.iter().all(|&b| b == first)
}

#[cfg(test)]
mod tests;
