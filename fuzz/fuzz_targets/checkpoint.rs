//! The GA checkpoint a preflight resumes from after a power loss (version 2, and version 1 of
//! eight genes): `SteadyStateGa::restore` never panics; a GA it accepts saves to a record that restores to the same GA (the reader
//! ignores what the format leaves unused, e.g. the pending genes when none is pending, so the
//! bytes themselves need not come back), keeps every gene in [0, 1], and can be asked for its
//! next candidate.
//!
//! Input: bytes 0..4 the run fingerprint (little-endian), then the record; bit 0 of byte 0
//! set re-seals the record's trailing CRC-32.
#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;
use shared::fdi::POPULATION;
use shared::{GaSettings, SteadyStateGa};

fuzz_target!(|data: &[u8]| {
    if data.len() < 4 {
        return;
    }
    let (head, body) = data.split_at(4);
    let fingerprint = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
    let record = if head[0] & 1 == 1 {
        common::sealed(body.to_vec())
    } else {
        body.to_vec()
    };
    let Ok(mut ga) = SteadyStateGa::<POPULATION>::restore(GaSettings::FDI, fingerprint, &record)
    else {
        return;
    };
    // The current version's length: a version-1 record (eight genes) restores too, and saves
    // as the current version.
    let mut again = vec![0u8; SteadyStateGa::<POPULATION>::RECORD_BYTES];
    ga.save(fingerprint, &mut again)
        .expect("a record of the right length");
    let back = SteadyStateGa::<POPULATION>::restore(GaSettings::FDI, fingerprint, &again)
        .expect("our own record restores");
    assert!(back == ga, "save then restore changed the GA");
    for m in ga.population() {
        assert!(
            m.genes.iter().all(|g| (0.0..=1.0).contains(g)),
            "{:?}",
            m.genes
        );
    }
    if let Ok(genes) = ga.ask() {
        assert!(genes.iter().all(|g| (0.0..=1.0).contains(g)), "{genes:?}");
    }
});
