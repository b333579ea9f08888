//! The health log as the controller keeps it and `host-sim fleet ingest` reads it: every
//! slot through `HealthRecord::decode`, the image's slot size (`files::health::slot_bytes`),
//! the ingest's image reader (`ImageStore`), and the in-place upgrade of older slots
//! (`shared::health::upgrade_image`). None may panic; a record that decodes encodes back to a
//! record that decodes equal; an upgrade keeps no more records than there are slots.
//!
//! Input: byte 0 is the mode; its low three bits re-seal each slot's trailing CRC-32: 1 the
//! current 84-byte slots (version 4), 2 the 68-byte (version 2), 3 the 52-byte (version 1),
//! 4 the 76-byte (version 3, eight components); others leave the bytes as they are.
#![no_main]

#[path = "common.rs"]
mod common;

use host_sim::files::health::{slot_bytes, ImageStore};
use libfuzzer_sys::fuzz_target;
use shared::health::{
    upgrade_image, HealthRecord, RECORD_BYTES, RECORD_V1_BYTES, RECORD_V2_BYTES, RECORD_V3_BYTES,
};

fn bits_equal(a: &HealthRecord, b: &HealthRecord) -> bool {
    // Compared through the encoding: NaN fields compare by bits.
    a.encode() == b.encode()
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, body)) = data.split_first() else {
        return;
    };
    let slot = match mode & 7 {
        1 => RECORD_BYTES,
        2 => RECORD_V2_BYTES,
        3 => RECORD_V1_BYTES,
        4 => RECORD_V3_BYTES,
        _ => 0,
    };
    let image: Vec<u8> = if slot == 0 {
        body.to_vec()
    } else {
        body.chunks(slot)
            .flat_map(|c| common::sealed(c.to_vec()))
            .collect()
    };
    for chunk in image.chunks(RECORD_BYTES) {
        if let Ok(r) = HealthRecord::decode(chunk) {
            let again = HealthRecord::decode(&r.encode()).expect("our own encoding decodes");
            assert!(bits_equal(&again, &r));
        }
    }
    let _ = slot_bytes(&image);
    if let Ok(store) = ImageStore::new(&image) {
        let _ = store.version();
        for bytes in store.slots_bytes() {
            let _ = HealthRecord::decode(bytes);
        }
    }
    for old in [RECORD_V1_BYTES, RECORD_V2_BYTES, RECORD_V3_BYTES] {
        let slots = image.len() / RECORD_BYTES;
        let mut copy = image.clone();
        let kept = upgrade_image(&mut copy, slots, old);
        assert!(kept <= slots);
        assert_eq!(copy.len(), image.len());
    }
});
