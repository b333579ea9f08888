//! The image's RTT up-channel 0 (SEGGER's control block, `_SEGGER_RTT`), read from target
//! RAM as a probe does: the bytes between the read and the write offsets, then the read
//! offset moved up. Its bytes are defmt frames for `defmt-print`. O(bytes) per drain.

use unicorn_engine::Unicorn;

/// Offset of up-buffer 0's descriptor in the control block, and of its fields.
const UP0: u64 = 24;
const BUFFER: u64 = 4;
const SIZE: u64 = 8;
const WRITE: u64 = 12;
const READ: u64 = 16;

fn word<D>(uc: &Unicorn<'_, D>, at: u64) -> Option<u32> {
    let mut b = [0u8; 4];
    uc.mem_read(at, &mut b).ok()?;
    Some(u32::from_le_bytes(b))
}

/// Appends what channel 0 holds to `out`. `None` before the image has set the block up.
pub fn drain<D>(uc: &mut Unicorn<'_, D>, block: u32, out: &mut Vec<u8>) -> Option<usize> {
    let mut id = [0u8; 10];
    uc.mem_read(u64::from(block), &mut id).ok()?;
    if &id != b"SEGGER RTT" {
        return None;
    }
    let d = u64::from(block) + UP0;
    let (buffer, size, write, read) = (
        word(uc, d + BUFFER)?,
        word(uc, d + SIZE)?,
        word(uc, d + WRITE)?,
        word(uc, d + READ)?,
    );
    if size == 0 || write >= size || read >= size || write == read {
        return Some(0);
    }
    let mut taken = 0;
    let mut at = read;
    while at != write {
        let end = if write > at { write } else { size };
        let mut chunk = vec![0u8; (end - at) as usize];
        uc.mem_read(u64::from(buffer + at), &mut chunk).ok()?;
        out.extend_from_slice(&chunk);
        taken += chunk.len();
        at = if end == size { 0 } else { end };
    }
    uc.mem_write(d + READ, &write.to_le_bytes()).ok()?;
    Some(taken)
}
