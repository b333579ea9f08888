//! After each preflight, and after each flight's windows: the controller appends the test's
//! record (or the flight's reading) to its health log and re-assesses every trend and
//! remaining useful life — each fault's and the weak magnet's depth's (`shared::health`,
//! `shared::prognosis`). Host-tested; the binary keeps the store in RAM under emulation
//! (loaded from and saved to a semihosting file) and would keep it in flash on hardware.
//!
//! Work bound: one survey of the store (a read per slot, `shared::health::ONBOARD_RECORDS`
//! slots), one slot read and write (`health::write_after`), then per trended quantity
//! (`shared::prognosis::TREND_COUNT`) one replay of the store (a read and a trend update per
//! slot, O(slots · shapes)) and one estimate (O(shapes · 136)); measured: 34.0 M cycles with
//! 32 records under QEMU (BENCHMARKS.md §1). Stack: one trend (976 B), one estimate's shared
//! state and one slot's bytes, no copy of the log (the emulation image's painted peak by the
//! end of the health step, the identification's frames before it included: 20 400 B).

use shared::health::{
    self, HealthLogError, HealthRecord, HealthStore, LoadSummary, Newest, RecordedDay,
};
use shared::prognosis::{is_trended, FaultTrend, TrendEstimate, TrendSettings, TREND_COUNT};
use shared::FAULT_COUNT;

use crate::preflight::Report;

/// What the log and the trend say after this preflight.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub struct HealthUpdate {
    /// What the store held before this record.
    pub loaded: LoadSummary,
    /// This preflight's record.
    pub record: HealthRecord,
    /// Records in the store now, in flight order (earlier laps of the ring not counted).
    pub records: u32,
    /// The record this one overwrote in its slot (`flight − slots` when the ring is full).
    pub evicted: Option<HealthRecord>,
    /// Records not used by the trend (outside the monitor model's domain).
    pub skipped: u32,
    /// Every trended quantity's trend and RUL (`shared::prognosis::TREND_NAMES`; `None`: the
    /// eccentricity phase, or fewer than three trusted records).
    pub estimates: [Option<TrendEstimate>; TREND_COUNT],
}

/// Appends `report`, and the test's `day`, as the record of `flight` (default: one after the
/// newest in the store, 0 for an empty store) and assesses the trend over the store
/// ([`record_entry`]).
pub fn record_preflight<S: HealthStore>(
    store: &mut S,
    flight: Option<u32>,
    report: &Report,
    day: RecordedDay,
    settings: &TrendSettings,
) -> Result<HealthUpdate, HealthLogError<S::Error>> {
    record_entry(
        store,
        |newest| preflight_entry(flight, newest, report, day),
        settings,
    )
}

/// The record of a preflight's `report` on `day` as flight `flight` (default: one after the
/// store's `newest`, 0 for an empty store). O(1).
pub fn preflight_entry(
    flight: Option<u32>,
    newest: Option<Newest>,
    report: &Report,
    day: RecordedDay,
) -> HealthRecord {
    test_record(preflight_flight(flight, newest), report, day)
}

/// The flight a preflight's record is of: `flight`, or one after the store's `newest` (0 for
/// an empty store). O(1).
pub fn preflight_flight(flight: Option<u32>, newest: Option<Newest>) -> u32 {
    flight.unwrap_or_else(|| newest.map_or(0, |n| n.flight.saturating_add(1)))
}

/// The record of one test's `report` on `day` as flight `flight`: what a preflight of one test
/// logs, and what each of a repeated preflight's tests adds to its mean
/// (`shared::repeat::RepeatedTests`). O(1).
pub fn test_record(flight: u32, report: &Report, day: RecordedDay) -> HealthRecord {
    HealthRecord::new(
        flight,
        report.result.faults,
        report.result.fitness,
        report.domain,
    )
    .with_std(
        report
            .uncertainty
            .map_or([f32::NAN; FAULT_COUNT], |u| u.std),
    )
    .with_day(day)
    .with_magnet(&report.result.magnets)
    .with_magnet_std(report.uncertainty.map_or(f32::NAN, |u| u.magnet_std))
}

/// Appends the record `entry` makes of the store's newest record (a preflight, or a flight's
/// reading from its windows: `HealthRecord::of_flight_reading`) and assesses the trend over
/// the store, preflights and flights' readings alike. No copy of the log is made: the store
/// is surveyed, the record written after the newest, and each trended quantity's trend
/// replays the store in order (one trend of 976 bytes, reused).
pub fn record_entry<S: HealthStore>(
    store: &mut S,
    entry: impl FnOnce(Option<Newest>) -> HealthRecord,
    settings: &TrendSettings,
) -> Result<HealthUpdate, HealthLogError<S::Error>> {
    let (loaded, newest) = health::survey(store).map_err(HealthLogError::Store)?;
    let record = entry(newest);
    let written = health::write_after(store, &record, newest)?;
    // One fault at a time, in one trend; the same bits as a `HealthTrend` over the log. Each
    // replay also counts the records and those outside the domain.
    let mut estimates = [None; TREND_COUNT];
    let mut trend = FaultTrend::new();
    let (mut records, mut skipped) = (0, 0);
    for (i, e) in estimates.iter_mut().enumerate() {
        if is_trended(i) {
            trend.clear();
            skipped = 0;
            records = health::replay(store, written.slot, |r| {
                if r.is_trusted() {
                    trend.add(r, i, settings);
                } else {
                    skipped += 1;
                }
            })
            .map_err(HealthLogError::Store)?;
            *e = trend.estimate(settings.threshold(i), settings);
        }
    }
    Ok(HealthUpdate {
        loaded,
        record,
        records,
        evicted: written.replaced,
        skipped,
        estimates,
    })
}
