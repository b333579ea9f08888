//! After each preflight: the controller appends the test's record to its health log and
//! re-assesses every fault's trend and remaining useful life (`shared::health`,
//! `shared::prognosis`). Host-tested; the binary keeps the store in RAM under emulation
//! (loaded from and saved to a semihosting file) and would keep it in flash on hardware.
//!
//! Work bound: two store reads per slot ([`ONBOARD_RECORDS`]), one slot write, one trend
//! update per record (O(records · faults · rates)) and one estimate per fault (O(rates ·
//! horizon)). Stack: the log (≈ 1.8 KiB) and one fault's trend (976 B), held only during
//! the call.

use shared::health::{
    HealthLog, HealthLogError, HealthRecord, HealthStore, LoadSummary, ONBOARD_RECORDS,
};
use shared::prognosis::{is_trended, FaultTrend, TrendEstimate, TrendSettings};
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
    /// Records in the log now.
    pub records: u32,
    /// The record that left the ring to make room, if any.
    pub evicted: Option<HealthRecord>,
    /// Records not used by the trend (outside the monitor model's domain).
    pub skipped: u32,
    /// Every fault's trend and RUL (`None`: the eccentricity phase, or fewer than three
    /// trusted records).
    pub estimates: [Option<TrendEstimate>; FAULT_COUNT],
}

/// Appends `report` as the record of `flight` (default: one after the newest in the store, 0
/// for an empty store) and assesses the trend over the log.
pub fn record_preflight<S: HealthStore>(
    store: &mut S,
    flight: Option<u32>,
    report: &Report,
    settings: &TrendSettings,
) -> Result<HealthUpdate, HealthLogError<S::Error>> {
    let (mut log, loaded) =
        HealthLog::<ONBOARD_RECORDS>::load(store).map_err(HealthLogError::Store)?;
    let flight = flight.unwrap_or_else(|| log.latest().map_or(0, |r| r.flight.saturating_add(1)));
    let record = HealthRecord::new(
        flight,
        report.result.faults,
        report.result.fitness,
        report.domain,
    )
    .with_std(
        report
            .uncertainty
            .map_or([f32::NAN; FAULT_COUNT], |u| u.std),
    );
    let evicted = log.append(store, record)?;
    // One fault at a time (976 bytes of trend state); the same bits as a `HealthTrend`.
    let mut estimates = [None; FAULT_COUNT];
    for (i, e) in estimates.iter_mut().enumerate() {
        if is_trended(i) {
            *e = FaultTrend::from_records(log.iter(), i, settings)
                .estimate(settings.threshold(i), settings);
        }
    }
    Ok(HealthUpdate {
        loaded,
        record,
        records: log.len() as u32,
        evicted,
        skipped: log.iter().filter(|r| !r.is_trusted()).count() as u32,
        estimates,
    })
}
