//! The board's flash pairs as read at boot and by `host-sim flash-pair --read`: `AbStore`
//! over whatever the two pages hold (a torn write, a half-erased page, a dump of the wrong
//! sectors) never panics; a write then succeeds, and reads back as the newest item — exactly
//! the item written when the pages held no sound entry before.
//!
//! Input: byte 0 the item's length (0–127; bit 7 set re-seals every entry the pages hold:
//! wherever a header's magic and length fit, its CRC and commit word are made whole, so that
//! the fuzzer reaches sound entries of any sequence), then the two 4 KiB pages' contents (the
//! rest erased, 0xFF).
#![no_main]

use embedded_storage::nor_flash::NorFlash;
use firmware::storage::{AbStore, RamFlash};
use libfuzzer_sys::fuzz_target;

const PAGE: usize = 4096;
type Pair = RamFlash<2, PAGE>;

fuzz_target!(|data: &[u8]| {
    let Some((&len, contents)) = data.split_first() else {
        return;
    };
    let mut image = vec![0xFFu8; 2 * PAGE];
    let n = contents.len().min(image.len());
    image[..n].copy_from_slice(&contents[..n]);
    if len & 0x80 != 0 {
        for page in image.chunks_exact_mut(PAGE) {
            reseal(page);
        }
    }
    let len = len & 0x7F;
    let mut flash = Box::new(Pair::ERASED);
    // Programmed words as given; erased words left erased (still writable, as on a chip).
    for (i, word) in image.chunks_exact(4).enumerate() {
        if word != [0xFF; 4] {
            flash
                .write(4 * i as u32, word)
                .expect("a word inside the flash");
        }
    }
    let mut store = AbStore::new(&mut *flash, 0, PAGE as u32).expect("two pages");
    let mut out = vec![0u8; PAGE];
    let before = store
        .read(&mut out)
        .expect("reading never fails on a RAM flash");
    let item: Vec<u8> = (0..usize::from(len)).map(|i| i as u8 ^ len).collect();
    store.write(&item).expect("a write fits one page");
    let after = store
        .read(&mut out)
        .expect("readable")
        .expect("the item just written");
    if before.is_none() {
        assert_eq!(&out[..after], &item[..]);
    }
});

/// Makes whole, in place, every entry whose header (magic, sequence, length) fits the page,
/// walking the page as the store does.
fn reseal(page: &mut [u8]) {
    let mut at = 0;
    while at + 20 <= page.len() {
        let word = |i: usize| u32::from_le_bytes(page[i..i + 4].try_into().unwrap());
        if word(at) != u32::from_le_bytes(*b"EMAB") {
            return;
        }
        let Some(padded) = (word(at + 8) as usize).checked_next_multiple_of(4) else {
            return;
        };
        let end = at + 12 + padded;
        if end + 8 > page.len() {
            return;
        }
        let mut crc = shared::trace::Crc32::new();
        crc.update(&page[at..end]);
        let sum = crc.finish();
        page[end..end + 4].copy_from_slice(&sum.to_le_bytes());
        page[end + 4..end + 8].copy_from_slice(&(!sum).to_le_bytes());
        at = end + 8;
    }
}
