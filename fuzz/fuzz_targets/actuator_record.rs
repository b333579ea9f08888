//! The actuator record the firmware loads and `host-sim actuator` reads: `ActuatorRecord::
//! decode` never panics, and a record it accepts encodes back to a record that decodes to the
//! same bits (every version decodes to the current one). The host's description-file parser
//! (`Actuator::parse`, TOML) gets the same bytes as text and may not panic either.
//!
//! Input: byte 0 is the mode; bit 0 set re-seals the record's trailing CRC-32.
#![no_main]

#[path = "common.rs"]
mod common;

use host_sim::files::actuator::Actuator;
use libfuzzer_sys::fuzz_target;
use shared::actuator::ActuatorRecord;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, body)) = data.split_first() else {
        return;
    };
    let bytes = if mode & 1 == 1 {
        common::sealed(body.to_vec())
    } else {
        body.to_vec()
    };
    if let Ok(record) = ActuatorRecord::decode(&bytes) {
        let again = ActuatorRecord::decode(&record.encode()).expect("our own encoding decodes");
        // Compared bit for bit: the polish's probe slots beyond its `probe_count` are carried
        // as they were written and never used, so they may hold a NaN, which `==` on the
        // decoded records would call unequal to itself (seed `unused-probe-nan`).
        assert_eq!(again.encode(), record.encode());
    }
    if mode & 2 == 2 {
        if let Ok(text) = std::str::from_utf8(body) {
            let _ = Actuator::parse(text);
        }
    }
});
