//! Power cut at every word of every write and erase of every store operation (the actuator
//! record, the GA checkpoint, the health log): after each cut the flash powers up, the stores
//! open, nothing that was committed before the operation is lost, the operation's own item is
//! either whole or absent, nothing half-written is read, and the store takes the next write.
//!
//! The flash is `RamFlash`: 4-byte words written at most once between erases, a cut word
//! left half-programmed, a cut erase leaving its page half-erased.

use firmware::storage::{RamFlash, RecordStore, StorageLayout};
use futures::executor::block_on;

const PAGE: usize = 4096;
const PAGES: usize = 8;
type Flash = RamFlash<PAGES, PAGE>;

/// Record 2 pages, checkpoint 2, health log 4.
fn layout() -> StorageLayout {
    StorageLayout {
        record: 0..2 * PAGE as u32,
        checkpoint: 2 * PAGE as u32..4 * PAGE as u32,
        health: 4 * PAGE as u32..8 * PAGE as u32,
    }
}

fn copy(flash: &Flash) -> Box<Flash> {
    let mut out = Box::new(Flash::ERASED);
    out.copy_from(flash);
    out
}

/// What the stores hold, read back after a power-up.
#[derive(Debug, PartialEq)]
struct Contents {
    record: Option<Vec<u8>>,
    checkpoint: Option<Vec<u8>>,
    health: Vec<Vec<u8>>,
}

fn store(flash: &mut Flash) -> RecordStore<&mut Flash> {
    RecordStore::new(flash, layout()).expect("the layout fits")
}

/// Reads every store; fails the test if a store cannot be read.
fn contents(flash: &mut Flash) -> Contents {
    let mut s = store(flash);
    let mut buffer = vec![0u8; 2048];
    let record = block_on(s.record(&mut buffer))
        .expect("record store opens")
        .map(<[u8]>::to_vec);
    let checkpoint = block_on(s.checkpoint(&mut buffer))
        .expect("checkpoint store opens")
        .map(<[u8]>::to_vec);
    let mut health = Vec::new();
    block_on(s.health_records(&mut buffer, |r| health.push(r.to_vec()))).expect("health log opens");
    Contents {
        record,
        checkpoint,
        health,
    }
}

/// A distinct item of `len` bytes, numbered `n` (its first four bytes).
fn item(n: u32, len: usize) -> Vec<u8> {
    let mut v: Vec<u8> = (0..len)
        .map(|i| (i as u32).wrapping_mul(31).wrapping_add(n * 7) as u8)
        .collect();
    v[..4].copy_from_slice(&n.to_le_bytes());
    v
}

#[derive(Clone, Copy, Debug)]
enum Op {
    Record(u32),
    Checkpoint(u32),
    EmptyCheckpoint,
    Health(u32),
}

const RECORD_LEN: usize = 432;
const CHECKPOINT_LEN: usize = 1276;
const HEALTH_LEN: usize = 76;

fn run(flash: &mut Flash, op: Op) -> bool {
    let mut s = store(flash);
    let mut buffer = vec![0u8; 2048];
    match op {
        Op::Record(n) => block_on(s.store_record(&item(n, RECORD_LEN), &mut buffer)).is_ok(),
        Op::Checkpoint(n) => {
            block_on(s.store_checkpoint(&item(n, CHECKPOINT_LEN), &mut buffer)).is_ok()
        }
        Op::EmptyCheckpoint => block_on(s.store_checkpoint(&[], &mut buffer)).is_ok(),
        Op::Health(n) => block_on(s.append_health(&item(n, HEALTH_LEN))).is_ok(),
    }
}

/// Whether `after` (read after a cut during `op` from `before`) is a state the guarantee
/// allows: the other stores as they were; the touched one as before or as `done` (the
/// operation finished) — for the health log also `done` without the new record (the oldest
/// page was let go to make room, the new record not yet written).
fn allowed(before: &Contents, done: &Contents, after: &Contents, op: Op) -> bool {
    match op {
        Op::Record(_) => {
            after.checkpoint == before.checkpoint
                && after.health == before.health
                && (after.record == before.record || after.record == done.record)
        }
        Op::Checkpoint(_) | Op::EmptyCheckpoint => {
            after.record == before.record
                && after.health == before.health
                && (after.checkpoint == before.checkpoint || after.checkpoint == done.checkpoint)
        }
        Op::Health(_) => {
            let without_new = &done.health[..done.health.len().saturating_sub(1)];
            after.record == before.record
                && after.checkpoint == before.checkpoint
                && (after.health == before.health
                    || after.health == done.health
                    || after.health == without_new)
        }
    }
}

/// Does `op` on `flash`, first cutting the power at every word it writes or erases (each on a
/// copy, checked after power-up, then written to again). Returns the cut points tried.
fn every_cut(flash: &mut Box<Flash>, op: Op) -> u64 {
    let before = contents(&mut copy(flash));
    let mut whole = copy(flash);
    let start = whole.words;
    assert!(run(&mut whole, op), "{op:?} fails without a cut");
    let length = whole.words - start;
    let done = contents(&mut copy(&whole));
    let (mut as_before, mut as_done, mut made_room) = (0u64, 0u64, 0u64);
    for cut in 0..length {
        let mut cut_flash = copy(flash);
        cut_flash.cut_after = Some(cut as u32);
        assert!(
            !run(&mut cut_flash, op),
            "{op:?} ignored a cut at word {cut}"
        );
        cut_flash.power_up();
        let after = contents(&mut cut_flash);
        assert!(
            allowed(&before, &done, &after, op),
            "{op:?} cut at word {cut} of {length}:\nbefore {before:?}\nafter {after:?}"
        );
        as_before += u64::from(after == before);
        as_done += u64::from(after == done);
        made_room += u64::from(after != before && after != done);
        // The stores take the next write and read it back.
        assert!(
            run(&mut cut_flash, Op::Health(9_999)),
            "{op:?} cut at {cut}: no next write"
        );
        assert_eq!(
            contents(&mut cut_flash).health.last(),
            Some(&item(9_999, HEALTH_LEN))
        );
    }
    // The operation changes what is read, and every cut ended in one of the allowed states.
    // (Measured: the item becomes readable only with the operation's last word, so a cut
    // leaves the old state — or, while the log makes room, the old state less the oldest
    // page it was letting go.)
    assert_ne!(before, done, "{op:?} changed nothing");
    assert_eq!(as_before + as_done + made_room, length, "{op:?}");
    assert!(made_room == 0 || matches!(op, Op::Health(_)), "{op:?}");
    *flash = whole;
    length
}

#[test]
fn the_actuator_record_survives_a_cut_anywhere() {
    // The first record on an erased flash, then replacements across a page change.
    let mut flash = Box::new(Flash::ERASED);
    let mut cuts = 0;
    for n in 1..=12 {
        cuts += every_cut(&mut flash, Op::Record(n));
    }
    assert!(flash.erases[..2].iter().any(|&e| e > 0), "no page change");
    assert_eq!(contents(&mut flash).record, Some(item(12, RECORD_LEN)));
    println!("record: {cuts} cut points");
    assert!(cuts > 12 * 110, "{cuts}");
}

#[test]
fn the_checkpoint_survives_a_cut_anywhere_including_page_changes() {
    // 1 276-byte checkpoints, three to a 4 KiB page: the store moves between the two pages
    // and erases. Then the finished preflight's empty checkpoint.
    let mut flash = Box::new(Flash::ERASED);
    let mut cuts = 0;
    for n in 1..=7 {
        cuts += every_cut(&mut flash, Op::Checkpoint(n));
    }
    assert_eq!(
        contents(&mut flash).checkpoint,
        Some(item(7, CHECKPOINT_LEN))
    );
    cuts += every_cut(&mut flash, Op::EmptyCheckpoint);
    assert_eq!(contents(&mut flash).checkpoint, None);
    assert!(flash.erases[2..4].iter().any(|&e| e > 0), "no page change");
    println!("checkpoint: {cuts} cut points");
    assert!(cuts > 7 * 320, "{cuts}");
}

#[test]
fn the_health_log_survives_a_cut_anywhere_including_rotation() {
    // 76-byte records, four 4 KiB pages: about 190 fill the log; the next ones let the oldest
    // page go. Cuts at every word of the first 3 and of the 60 around the first rotation.
    let mut flash = Box::new(Flash::ERASED);
    let mut cuts = 0;
    for n in 0..3 {
        cuts += every_cut(&mut flash, Op::Health(n));
    }
    for n in 3..150 {
        assert!(run(&mut flash, Op::Health(n)));
    }
    for n in 150..210 {
        cuts += every_cut(&mut flash, Op::Health(n));
    }
    let last = contents(&mut flash).health;
    assert!(
        flash.erases[4..].iter().any(|&e| e > 0),
        "the log never rotated"
    );
    assert!(last.len() < 210, "{}", last.len());
    // The newest records are all there, oldest first, none repeated or skipped.
    assert_eq!(last.last(), Some(&item(209, HEALTH_LEN)));
    let numbers: Vec<u32> = last
        .iter()
        .map(|r| u32::from_le_bytes(r[..4].try_into().unwrap()))
        .collect();
    assert!(numbers.windows(2).all(|w| w[1] == w[0] + 1), "{numbers:?}");
    println!("health log: {cuts} cut points");
    assert!(cuts > 63 * 20, "{cuts}");
}

#[test]
fn a_layout_that_does_not_fit_the_pages_is_refused() {
    let mut flash = Flash::ERASED;
    let mut bad = layout();
    bad.checkpoint = 2 * PAGE as u32..3 * PAGE as u32; // one page: a map needs two
    assert!(RecordStore::new(&mut flash, bad).is_err());
}

fn s_words(s: &mut RecordStore<&mut RamFlash<6, { 128 * 1024 }>>) -> u64 {
    s.flash().words
}

/// Flash wear over 20 years of four flights a day (29 220 flights) on the STM32F405's 128 KiB
/// sectors (`StorageLayout::STM32F405`'s page size; two sectors per store), measured on 365
/// flights (three months) and scaled: each flight stores two GA checkpoints (every 500 of its
/// ≤ 1 440 evaluations) and the empty one that ends it, and appends one health record. The
/// health log does not fill a sector in three months: its erases are its flash bytes per
/// record, measured, over the 20 years' records. The sectors are rated for 10 000 erase
/// cycles.
#[test]
fn twenty_years_of_flights_wear_each_sector_far_below_its_rating() {
    const SECTOR: usize = 128 * 1024;
    type Board = RamFlash<6, SECTOR>;
    let run = || {
        let mut flash = Box::new(Board::ERASED);
        let layout = StorageLayout {
            record: 0..2 * SECTOR as u32,
            checkpoint: 2 * SECTOR as u32..4 * SECTOR as u32,
            health: 4 * SECTOR as u32..6 * SECTOR as u32,
        };
        let mut s = RecordStore::new(&mut *flash, layout).unwrap();
        let mut buffer = vec![0u8; 2048];
        block_on(s.store_record(&item(0, RECORD_LEN), &mut buffer)).unwrap();
        let flights = 365u32;
        let mut health_words = 0;
        for f in 0..flights {
            for c in 0..2 {
                block_on(s.store_checkpoint(&item(f * 2 + c, CHECKPOINT_LEN), &mut buffer))
                    .unwrap();
            }
            block_on(s.store_checkpoint(&[], &mut buffer)).unwrap();
            let start = s_words(&mut s);
            block_on(s.append_health(&item(f, HEALTH_LEN))).unwrap();
            health_words += s_words(&mut s) - start;
        }
        let scale = 29_220.0 / f64::from(flights);
        let mut erases = flash.erases.map(|e| f64::from(e) * scale);
        // The log lets one sector go each time it fills one: records per sector from the
        // bytes each took.
        let bytes_per_record = 4.0 * health_words as f64 / f64::from(flights);
        let per_sector = (SECTOR as f64 / bytes_per_record).floor();
        let log_erases = (29_220.0 - 2.0 * per_sector).max(0.0) / per_sector;
        erases[4] = (log_erases / 2.0).ceil();
        erases[5] = (log_erases / 2.0).ceil();
        println!("health record: {bytes_per_record} bytes of flash, {per_sector} per sector");
        println!("erase cycles per sector over 20 years (record, record, checkpoint, checkpoint, health, health): {erases:.0?}");
        erases
    };
    // The 768 KiB flash and its write map are built in place on a thread with room for them.
    let erases = std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(run)
        .unwrap()
        .join()
        .unwrap();
    assert!(
        erases[2] > 0.0 && erases[3] > 0.0,
        "the checkpoint never changed page"
    );
    assert!(erases.iter().all(|&e| e < 10_000.0 / 4.0), "{erases:?}");
}

/// The A/B pair (`AbStore`, the compact store the board uses for the actuator record, the
/// checkpoint and the health image): a cut at every word of every erase and write of a run of
/// stores — items appended in a page, then the page change that erases the other one — leaves
/// the previous item readable (or, once the commit word is whole, the new one), never a torn
/// one, and the next store works. Checkpoint-sized items (3 to a 4 KiB page) and health-sized
/// ones (42 to a page).
fn ab_cuts(len: usize, stores: u32) -> (u64, u32) {
    use firmware::storage::AbStore;
    type Small = RamFlash<2, PAGE>;
    fn open(f: &mut Small) -> AbStore<&mut Small> {
        AbStore::new(f, 0, PAGE as u32).expect("two pages")
    }
    let read = |f: &mut Small| -> Option<Vec<u8>> {
        let mut buffer = vec![0u8; 2048];
        let n = open(f).read(&mut buffer).expect("readable")?;
        Some(buffer[..n].to_vec())
    };
    let store = |f: &mut Small, n: u32| open(f).write(&item(n, len)).is_ok();
    let mut flash = Box::new(Small::ERASED);
    let mut cuts = 0u64;
    for n in 1..=stores {
        let before = read(&mut flash);
        let mut whole = Box::new(Small::ERASED);
        whole.copy_from(&flash);
        let start = whole.words;
        assert!(store(&mut whole, n));
        let length = whole.words - start;
        assert_eq!(read(&mut whole), Some(item(n, len)));
        for cut in 0..length {
            let mut copy = Box::new(Small::ERASED);
            copy.copy_from(&flash);
            copy.cut_after = Some(cut as u32);
            assert!(!store(&mut copy, n), "store {n} ignored a cut at {cut}");
            copy.power_up();
            let after = read(&mut copy);
            assert!(
                after == before || after == Some(item(n, len)),
                "store {n} cut at word {cut} of {length}: read {:?}",
                after.as_ref().map(|a| &a[..4])
            );
            assert!(
                store(&mut copy, 9_999),
                "no next write after a cut at {cut}"
            );
            assert_eq!(read(&mut copy), Some(item(9_999, len)));
            // And the one after that (a torn entry is stepped over, not written again).
            assert!(
                store(&mut copy, 10_000),
                "no second write after a cut at {cut}"
            );
            assert_eq!(read(&mut copy), Some(item(10_000, len)));
            cuts += 1;
        }
        flash = whole;
    }
    (cuts, flash.erases.iter().sum())
}

#[test]
fn the_ab_pair_survives_a_cut_anywhere() {
    use firmware::storage::AbStore;
    let (cuts, erases) = ab_cuts(CHECKPOINT_LEN, 12);
    println!("A/B pair, checkpoints: {cuts} cut points, {erases} page erases");
    // 12 items of 1 296 flash bytes, 3 to a page: the pages changed 3 times.
    assert_eq!(erases, 3);
    let (small_cuts, small_erases) = ab_cuts(HEALTH_LEN, 100);
    println!("A/B pair, health-sized: {small_cuts} cut points, {small_erases} page erases");
    assert_eq!(small_erases, 2);
    // A length that ends in a partial word (its padding written from a zeroed word).
    let (odd_cuts, odd_erases) = ab_cuts(451, 20);
    println!("A/B pair, 451 bytes: {odd_cuts} cut points, {odd_erases} page erases");
    assert_eq!(odd_erases, 2);
    // A layout of one page twice is refused.
    let mut f = RamFlash::<2, PAGE>::ERASED;
    assert!(AbStore::new(&mut f, 0, 0).is_err());
}

/// The board's stores (`AbStore` pairs of 128 KiB sectors) over 20 years of four flights a
/// day, measured on 365 flights and scaled: each flight stores two checkpoints and the empty
/// one that ends it in the checkpoint pair, and the health log's whole image (32 records of
/// 76 bytes) in the health pair. Rated 10 000 erase cycles.
#[test]
fn twenty_years_on_the_boards_ab_pairs_wear_each_sector_far_below_its_rating() {
    use firmware::storage::AbStore;
    const SECTOR: usize = 128 * 1024;
    const HEALTH_IMAGE: usize = 32 * HEALTH_LEN;
    type Pair = RamFlash<2, SECTOR>;
    let run = || {
        let mut checkpoint = Box::new(Pair::ERASED);
        let mut health = Box::new(Pair::ERASED);
        let flights = 365u32;
        for f in 0..flights {
            let mut s = AbStore::new(&mut *checkpoint, 0, SECTOR as u32).unwrap();
            for c in 0..2 {
                s.write(&item(f * 2 + c, CHECKPOINT_LEN)).unwrap();
            }
            s.write(&[]).unwrap();
            let mut h = AbStore::new(&mut *health, 0, SECTOR as u32).unwrap();
            h.write(&item(f, HEALTH_IMAGE)).unwrap();
        }
        let scale = 29_220.0 / f64::from(flights);
        let per_sector = |flash: &Pair| flash.erases.map(|e| (f64::from(e) * scale).ceil());
        let erases = [per_sector(&checkpoint), per_sector(&health)];
        println!(
            "erase cycles per sector over 20 years (checkpoint pair, health pair): {erases:.0?}"
        );
        erases
    };
    let erases = std::thread::Builder::new()
        .stack_size(8 << 20)
        .spawn(run)
        .unwrap()
        .join()
        .unwrap();
    // Both sectors of each pair took turns, and none came near its rating.
    assert!(
        erases
            .iter()
            .flatten()
            .all(|&e| e > 0.0 && e < 10_000.0 / 4.0),
        "{erases:?}"
    );
}

/// The board's pairs are the halves of the layout's ranges: one 128 KiB sector each.
#[test]
fn the_board_pairs_are_one_sector_each() {
    let l = StorageLayout::STM32F405;
    assert_eq!(StorageLayout::pair(&l.record), (0x0002_0000, 0x0004_0000));
    assert_eq!(StorageLayout::pair(&l.health), (0x000A_0000, 0x000C_0000));
}
