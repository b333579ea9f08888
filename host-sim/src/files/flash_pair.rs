//! The board's records as flash images (`host-sim flash-pair`): an A/B pair of the
//! controller's 128 KiB sectors (`firmware::storage::AbStore`, the layout
//! `StorageLayout::STM32F405`) holding one item, to flash at the pair's address — the
//! actuator record before the first preflight — and the newest item read back from a dump of
//! a pair — the health log's image after flights, for `fleet ingest` or `prognostics`.
//!
//! The bytes are the firmware's own: the image is written and read through `AbStore` over a
//! RAM flash of the same geometry, not by a second encoder.

use anyhow::{bail, Context, Result};
use embedded_storage::nor_flash::NorFlash;
use firmware::storage::{AbStore, RamFlash, StorageLayout};

/// One erase sector of the pair [bytes].
pub const SECTOR: usize = 128 * 1024;
/// The pair's image: both sectors [bytes].
pub const PAIR_BYTES: usize = 2 * SECTOR;
/// Where the controller's flash starts in its address space.
pub const FLASH_BASE: u32 = 0x0800_0000;

type Pair = RamFlash<2, SECTOR>;

/// Which of the board's three pairs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Store {
    /// The actuator record (sectors 5–6).
    Record,
    /// The GA checkpoint (sectors 7–8).
    Checkpoint,
    /// The health log's image (sectors 9–10).
    Health,
}

impl Store {
    /// The pair's first address on the controller.
    pub fn address(self) -> u32 {
        let layout = StorageLayout::STM32F405;
        let range = match self {
            Self::Record => layout.record,
            Self::Checkpoint => layout.checkpoint,
            Self::Health => layout.health,
        };
        FLASH_BASE + range.start
    }
}

fn pair_store(flash: &mut Pair) -> Result<AbStore<&mut Pair>> {
    AbStore::new(flash, 0, SECTOR as u32).map_err(|e| anyhow::anyhow!("flash pair: {e:?}"))
}

/// The image of a pair holding `item` as its only entry (the rest erased, 0xFF): flashing it
/// at the pair's address replaces whatever either sector held.
pub fn pair_image(item: &[u8]) -> Result<Vec<u8>> {
    let mut flash = Box::new(Pair::ERASED);
    let mut store = pair_store(&mut flash)?;
    if item.len() > store.capacity() {
        bail!(
            "{} bytes do not fit a {} KiB sector",
            item.len(),
            SECTOR / 1024
        );
    }
    store
        .write(item)
        .map_err(|e| anyhow::anyhow!("writing the pair: {e:?}"))?;
    Ok(flash.bytes().to_vec())
}

/// The newest whole item in `dump`, a pair's two sectors as read from the controller; `None`
/// when the pair holds none.
pub fn newest_item(dump: &[u8]) -> Result<Option<Vec<u8>>> {
    if dump.len() != PAIR_BYTES {
        bail!(
            "a pair's dump is {} bytes (two {} KiB sectors), this one {}",
            PAIR_BYTES,
            SECTOR / 1024,
            dump.len()
        );
    }
    let mut flash = Box::new(Pair::ERASED);
    // The programmed words as read; an erased word stays erased.
    for (i, word) in dump.chunks_exact(4).enumerate() {
        if word != [0xFF; 4] {
            flash
                .write(4 * i as u32, word)
                .map_err(|e| anyhow::anyhow!("loading the dump: {e:?}"))?;
        }
    }
    let mut store = pair_store(&mut flash)?;
    let mut out = vec![0u8; SECTOR];
    let n = store
        .read(&mut out)
        .map_err(|e| anyhow::anyhow!("reading the pair: {e:?}"))?;
    Ok(n.map(|n| {
        out.truncate(n);
        out
    }))
}

/// `host-sim flash-pair --write`: the pair image of the item in `item_path`.
pub fn write_pair_image(
    store: Store,
    item_path: &std::path::Path,
    out: &std::path::Path,
) -> Result<()> {
    let item =
        std::fs::read(item_path).with_context(|| format!("reading {}", item_path.display()))?;
    let image = pair_image(&item)?;
    std::fs::write(out, &image).with_context(|| format!("writing {}", out.display()))?;
    println!(
        "wrote {} ({} bytes: {} bytes of item in a pair of {} KiB sectors); flash it at {:#010x}",
        out.display(),
        image.len(),
        item.len(),
        SECTOR / 1024,
        store.address()
    );
    Ok(())
}

/// `host-sim flash-pair --read`: the newest item of the pair dumped in `dump_path`.
pub fn read_pair_dump(
    store: Store,
    dump_path: &std::path::Path,
    out: &std::path::Path,
) -> Result<()> {
    let dump =
        std::fs::read(dump_path).with_context(|| format!("reading {}", dump_path.display()))?;
    let Some(item) = newest_item(&dump)? else {
        bail!(
            "{} holds no whole item (a pair read from {:#010x}?)",
            dump_path.display(),
            store.address()
        );
    };
    std::fs::write(out, &item).with_context(|| format!("writing {}", out.display()))?;
    println!(
        "wrote {} ({} bytes, the pair's newest item)",
        out.display(),
        item.len()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::actuator::ActuatorRecord;

    #[test]
    fn a_record_round_trips_through_the_pair_image() {
        let record = ActuatorRecord::REFERENCE.encode();
        let image = pair_image(&record).unwrap();
        assert_eq!(image.len(), PAIR_BYTES);
        // The entry sits at the first sector's start; the second sector is erased.
        assert_eq!(&image[..4], b"EMAB");
        assert!(image[SECTOR..].iter().all(|&b| b == 0xFF));
        let back = newest_item(&image).unwrap().unwrap();
        assert_eq!(ActuatorRecord::decode(&back), Ok(ActuatorRecord::REFERENCE));
        // A damaged item byte: no whole item left.
        let mut damaged = image.clone();
        damaged[100] ^= 0x10;
        assert_eq!(newest_item(&damaged).unwrap(), None);
        assert!(newest_item(&image[..SECTOR]).is_err());
        assert_eq!(Store::Record.address(), 0x0802_0000);
        assert_eq!(Store::Health.address(), 0x080A_0000);
    }
}
