//! The trace readers alone, fast enough for millions of runs: the host's `Trace::from_bytes`
//! (CSV or binary, any version) and the firmware's `TraceSource` (binary, frame by frame).
//! Neither may panic; a trace the host accepts writes back as binary and reads back equal.
//!
//! Input: byte 0 is the mode; bit 0 set re-seals the file's trailing CRC-32 (binary).
#![no_main]

#[path = "common.rs"]
mod common;

use firmware::source::SliceBytes;
use firmware::{Acquired, CurrentSource, TraceSource};
use host_sim::files::trace::Trace;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, body)) = data.split_first() else {
        return;
    };
    let file = if mode & 1 == 1 {
        common::sealed(body.to_vec())
    } else {
        body.to_vec()
    };
    if let Ok(trace) = Trace::from_bytes(&file) {
        if let Ok(bin) = trace.to_bin() {
            let back = Trace::from_bytes(&bin).expect("our own binary is read back");
            assert_eq!(back.samples().len(), trace.samples().len());
            assert_eq!(back.test(), trace.test());
        }
    }
    let Ok(mut source) = TraceSource::open(SliceBytes::new(&file)) else {
        return;
    };
    let rows = source.header().rows;
    let mut frames = 0u32;
    loop {
        match source.next_frame() {
            Ok(Acquired::Frame(_)) => frames += 1,
            Ok(Acquired::NotYet) => continue,
            Ok(Acquired::EndOfTest) => break,
            Err(_) => return,
        }
        assert!(frames <= rows, "more frames than the header's {rows} rows");
    }
});
