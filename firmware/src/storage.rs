//! Records in NOR flash that survive power loss: the actuator record, the GA checkpoint and the
//! health log, through `sequential-storage` (power-fail-safe by design: an item is written
//! whole, with its CRC, before the one it replaces is let go, and a torn page is repaired on
//! the next open).
//!
//! * The actuator record and the checkpoint each live in a key-value map of their own
//!   (`MapStorage`, key 0), so that the often-written checkpoint never moves the record. A
//!   finished preflight stores an empty checkpoint (no erase-in-place needed).
//! * The health log is a FIFO queue (`QueueStorage`) of whole health records; when its pages
//!   are full the oldest records make room.
//! * [`AbStore`]: the compact alternative for one item (record or checkpoint), an A/B pair of
//!   pages with a commit word, for a controller whose flash cannot hold `sequential-storage`
//!   (it adds ≈ 17 kB to the image; README, "Records in flash").
//!
//! Generic over any `embedded-storage-async` [`NorFlash`]: the board's sectors, or a
//! RAM-backed flash ([`RamFlash`]) under emulation and in the host's power-cut tests. Every
//! call is one bounded flash operation sequence: O(items in the range) reads without a cache
//! (uncached), at most one page erase per store. No allocation; the caller lends the item
//! buffer.

use core::ops::Range;

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};
use sequential_storage::queue::{QueueConfig, QueueStorage};

/// A store without a cache: every operation reads what it needs from the flash.
type NoCache<K> = Cache<Uncached, Uncached, Uncached, K>;

/// Key of the one item in each map.
const KEY: u8 = 0;

/// Where each store lives, as byte offsets into the flash; each range whole pages, the maps
/// at least two (one is always kept free for the copy a page migration makes).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StorageLayout {
    pub record: Range<u32>,
    pub checkpoint: Range<u32>,
    pub health: Range<u32>,
}

impl StorageLayout {
    /// The STM32F405's 1 MiB flash, offsets from 0x0800_0000: the firmware in sectors 0–4,
    /// then two 128 KiB sectors each for the record (5–6), the checkpoint (7–8) and the
    /// health log (9–10); sector 11 is spare.
    pub const STM32F405: Self = Self {
        record: 0x0002_0000..0x0006_0000,
        checkpoint: 0x0006_0000..0x000A_0000,
        health: 0x000A_0000..0x000E_0000,
    };
}

/// Why a store operation failed.
#[derive(Debug, PartialEq)]
pub enum StorageError<E> {
    /// The layout does not fit the flash's pages (`which` names the range).
    Layout { which: &'static str },
    /// The flash or the store failed (a power cut mid-operation ends here too).
    Store(sequential_storage::Error<E>),
    /// The lent buffer cannot hold the item.
    BufferTooSmall,
}

impl<E> From<sequential_storage::Error<E>> for StorageError<E> {
    fn from(e: sequential_storage::Error<E>) -> Self {
        Self::Store(e)
    }
}

/// The three stores on one flash.
pub struct RecordStore<F: NorFlash> {
    flash: F,
    layout: StorageLayout,
}

impl<F: NorFlash> RecordStore<F> {
    /// Opens the stores of `layout` on `flash` (nothing is read until asked). O(1).
    pub fn new(flash: F, layout: StorageLayout) -> Result<Self, StorageError<F::Error>> {
        if MapConfig::<F>::try_new(layout.record.clone()).is_err() {
            return Err(StorageError::Layout { which: "record" });
        }
        if MapConfig::<F>::try_new(layout.checkpoint.clone()).is_err() {
            return Err(StorageError::Layout {
                which: "checkpoint",
            });
        }
        if QueueConfig::<F>::try_new(layout.health.clone()).is_err() {
            return Err(StorageError::Layout { which: "health" });
        }
        Ok(Self { flash, layout })
    }

    /// The flash, to look at (its wear, in tests).
    pub fn flash(&self) -> &F {
        &self.flash
    }

    /// The flash back (e.g. to reopen the stores after a reset).
    pub fn into_flash(self) -> F {
        self.flash
    }

    fn map(&mut self, range: Range<u32>) -> MapStorage<u8, &mut F, NoCache<u8>> {
        // The range was checked in `new`; a checked config cannot fail here.
        MapStorage::new(
            &mut self.flash,
            MapConfig::new(range),
            Cache::new_uncached(),
        )
    }

    async fn store(
        &mut self,
        range: Range<u32>,
        item: &[u8],
        buffer: &mut [u8],
    ) -> Result<(), StorageError<F::Error>> {
        if buffer.len() < item.len() + 8 {
            return Err(StorageError::BufferTooSmall);
        }
        self.map(range).store_item(buffer, &KEY, &item).await?;
        Ok(())
    }

    async fn fetch<'b>(
        &mut self,
        range: Range<u32>,
        buffer: &'b mut [u8],
    ) -> Result<Option<&'b [u8]>, StorageError<F::Error>> {
        let item: Option<&[u8]> = self.map(range).fetch_item(buffer, &KEY).await?;
        Ok(item.filter(|b| !b.is_empty()))
    }

    /// Stores the actuator record (its bytes as the record format writes them); the previous
    /// one stays readable until this one is whole. `buffer`: the record + 8 bytes.
    pub async fn store_record(
        &mut self,
        record: &[u8],
        buffer: &mut [u8],
    ) -> Result<(), StorageError<F::Error>> {
        self.store(self.layout.record.clone(), record, buffer).await
    }

    /// The last actuator record stored whole, if any.
    pub async fn record<'b>(
        &mut self,
        buffer: &'b mut [u8],
    ) -> Result<Option<&'b [u8]>, StorageError<F::Error>> {
        self.fetch(self.layout.record.clone(), buffer).await
    }

    /// Stores a GA checkpoint; an empty one says "no run to resume".
    pub async fn store_checkpoint(
        &mut self,
        checkpoint: &[u8],
        buffer: &mut [u8],
    ) -> Result<(), StorageError<F::Error>> {
        self.store(self.layout.checkpoint.clone(), checkpoint, buffer)
            .await
    }

    /// The last checkpoint stored whole, unless it was emptied.
    pub async fn checkpoint<'b>(
        &mut self,
        buffer: &'b mut [u8],
    ) -> Result<Option<&'b [u8]>, StorageError<F::Error>> {
        self.fetch(self.layout.checkpoint.clone(), buffer).await
    }

    fn queue(&mut self) -> QueueStorage<&mut F, NoCache<()>> {
        QueueStorage::new(
            &mut self.flash,
            QueueConfig::new(self.layout.health.clone()),
            Cache::new_uncached(),
        )
    }

    /// Appends one health record; when the log's pages are full, the oldest records go.
    pub async fn append_health(&mut self, record: &[u8]) -> Result<(), StorageError<F::Error>> {
        self.queue().push(record, true).await?;
        Ok(())
    }

    /// Hands every health record, oldest first, to `each`; returns how many. `buffer`: one
    /// record.
    pub async fn health_records(
        &mut self,
        buffer: &mut [u8],
        mut each: impl FnMut(&[u8]),
    ) -> Result<usize, StorageError<F::Error>> {
        let mut queue = self.queue();
        let mut iter = queue.iter().await?;
        let mut n = 0;
        while let Some(entry) = iter.next(buffer).await? {
            each(&entry[..]);
            n += 1;
        }
        Ok(n)
    }
}

/// One item (the actuator record or the GA checkpoint) in an A/B pair of erase pages, for a
/// controller whose flash cannot hold a general store: each write goes to the page not holding
/// the newest item — erased first, then the header (magic, sequence, length), the item and its
/// CRC-32, and last a commit word, the CRC's complement — so that a cut anywhere leaves that
/// page unreadable and the other page's item standing. A read takes the sound page with the
/// higher sequence. O(item) per operation, one page erase per write; no allocation.
pub struct AbStore<F: NorFlash> {
    flash: F,
    pages: [u32; 2],
}

/// First word of an [`AbStore`] page.
const AB_MAGIC: u32 = u32::from_le_bytes(*b"EMAB");
/// Header words before the item.
const AB_HEADER: u32 = 12;

/// Why an [`AbStore`] operation failed.
#[derive(Debug, PartialEq)]
pub enum AbError<E> {
    /// The two pages are not distinct whole erase pages.
    Layout,
    /// The item does not fit a page, or the buffer does not hold the item.
    TooLarge,
    /// The flash failed (a power cut mid-operation ends here).
    Flash(E),
}

impl<F: NorFlash> AbStore<F> {
    /// The pair of pages starting at `a` and `b` [byte offsets].
    pub fn new(flash: F, a: u32, b: u32) -> Result<Self, AbError<F::Error>> {
        let page = F::ERASE_SIZE as u32;
        let fits = |x: u32| {
            x % page == 0
                && (x as usize)
                    .checked_add(F::ERASE_SIZE)
                    .is_some_and(|end| end <= flash.capacity())
        };
        if a == b || !fits(a) || !fits(b) {
            return Err(AbError::Layout);
        }
        Ok(Self {
            flash,
            pages: [a, b],
        })
    }

    /// The flash back.
    pub fn into_flash(self) -> F {
        self.flash
    }

    /// The sequence and length of the item page `at` holds, if it is whole; `buffer` receives
    /// the item.
    async fn sound(
        &mut self,
        at: u32,
        buffer: &mut [u8],
    ) -> Result<Option<(u32, usize)>, AbError<F::Error>> {
        let mut head = [0u8; AB_HEADER as usize];
        self.flash
            .read(at, &mut head)
            .await
            .map_err(AbError::Flash)?;
        let word = |i: usize| {
            let mut w = [0u8; 4];
            if let Some(b) = head.get(i..i + 4) {
                w.copy_from_slice(b);
            }
            u32::from_le_bytes(w)
        };
        let (magic, sequence, len) = (word(0), word(4), word(8) as usize);
        // A damaged length may be anything: rounded up without overflow, then bounded.
        let Some(padded) = len.checked_next_multiple_of(4) else {
            return Ok(None);
        };
        if magic != AB_MAGIC
            || padded > F::ERASE_SIZE.saturating_sub(AB_HEADER as usize + 8)
            || padded > buffer.len()
        {
            return Ok(None);
        }
        let Some(data) = buffer.get_mut(..padded) else {
            return Ok(None);
        };
        self.flash
            .read(at + AB_HEADER, data)
            .await
            .map_err(AbError::Flash)?;
        let mut tail = [0u8; 8];
        self.flash
            .read(at + AB_HEADER + padded as u32, &mut tail)
            .await
            .map_err(AbError::Flash)?;
        let mut crc = shared::trace::Crc32::new();
        crc.update(&head);
        crc.update(data);
        let sum = crc.finish();
        let [s0, s1, s2, s3, c0, c1, c2, c3] = tail;
        let stored = u32::from_le_bytes([s0, s1, s2, s3]);
        let commit = u32::from_le_bytes([c0, c1, c2, c3]);
        Ok((stored == sum && commit == !sum).then_some((sequence, len)))
    }

    /// The page holding the newest whole item, its sequence and length.
    async fn newest(
        &mut self,
        buffer: &mut [u8],
    ) -> Result<Option<(usize, u32, usize)>, AbError<F::Error>> {
        let mut best: Option<(usize, u32, usize)> = None;
        for (i, at) in self.pages.into_iter().enumerate() {
            if let Some((sequence, len)) = self.sound(at, buffer).await? {
                if best.is_none_or(|(_, s, _)| sequence.wrapping_sub(s) as i32 > 0) {
                    best = Some((i, sequence, len));
                }
            }
        }
        Ok(best)
    }

    /// The newest item stored whole, if any.
    pub async fn read<'b>(
        &mut self,
        buffer: &'b mut [u8],
    ) -> Result<Option<&'b [u8]>, AbError<F::Error>> {
        let Some((i, _, len)) = self.newest(buffer).await? else {
            return Ok(None);
        };
        // Read the winner again: the other page's check may have overwritten the buffer.
        let at = self.pages.get(i).copied().unwrap_or(0);
        if self.sound(at, buffer).await?.is_none() {
            return Ok(None);
        }
        Ok(buffer.get(..len))
    }

    /// Stores `item` in the page not holding the newest one. `buffer`: at least the item's
    /// length rounded up to 4 bytes.
    pub async fn write(&mut self, item: &[u8], buffer: &mut [u8]) -> Result<(), AbError<F::Error>> {
        let Some(padded) = item.len().checked_next_multiple_of(4) else {
            return Err(AbError::TooLarge);
        };
        if padded > F::ERASE_SIZE.saturating_sub(AB_HEADER as usize + 8) || buffer.len() < padded {
            return Err(AbError::TooLarge);
        }
        let (target, sequence) = match self.newest(buffer).await? {
            Some((i, s, _)) => (1 - i, s.wrapping_add(1)),
            None => (0, 0),
        };
        let at = self.pages.get(target).copied().unwrap_or(0);
        self.flash
            .erase(at, at + F::ERASE_SIZE as u32)
            .await
            .map_err(AbError::Flash)?;
        let mut head = [0u8; AB_HEADER as usize];
        for (slot, word) in head
            .chunks_exact_mut(4)
            .zip([AB_MAGIC, sequence, item.len() as u32])
        {
            slot.copy_from_slice(&word.to_le_bytes());
        }
        let data = buffer.get_mut(..padded).ok_or(AbError::TooLarge)?;
        data.fill(0);
        data.get_mut(..item.len())
            .ok_or(AbError::TooLarge)?
            .copy_from_slice(item);
        let mut crc = shared::trace::Crc32::new();
        crc.update(&head);
        crc.update(data);
        let sum = crc.finish();
        self.flash.write(at, &head).await.map_err(AbError::Flash)?;
        self.flash
            .write(at + AB_HEADER, data)
            .await
            .map_err(AbError::Flash)?;
        let end = at + AB_HEADER + padded as u32;
        self.flash
            .write(end, &sum.to_le_bytes())
            .await
            .map_err(AbError::Flash)?;
        // Last: the commit word. Until it is whole the page reads as unsound.
        self.flash
            .write(end + 4, &(!sum).to_le_bytes())
            .await
            .map_err(AbError::Flash)
    }
}

/// A NOR flash in RAM: `PAGES` pages of `PAGE` bytes, written in 4-byte words, erased to
/// 0xFF. It keeps NOR's rules: a word is written at most once between erases (a second write
/// is refused), and writing only clears bits. Optionally it loses power: after
/// `cut_after` more words written or erased, the operation stops there — the word being
/// written is left half-programmed and the page being erased half-erased — and every later
/// operation fails until [`RamFlash::power_up`].
pub struct RamFlash<const PAGES: usize, const PAGE: usize> {
    bytes: [[u8; PAGE]; PAGES],
    written: [[bool; PAGE]; PAGES],
    /// Words left before the power is cut (`None`: never).
    pub cut_after: Option<u32>,
    powered: bool,
    /// Words written and erased so far, and pages erased, over the flash's life.
    pub words: u64,
    pub erases: [u32; PAGES],
}

/// What a [`RamFlash`] refuses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RamFlashError {
    NotAligned,
    OutOfBounds,
    /// The word was written since its page was last erased.
    WrittenTwice,
    /// The power was cut.
    PowerLost,
}

impl NorFlashError for RamFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::NotAligned => NorFlashErrorKind::NotAligned,
            Self::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            Self::WrittenTwice | Self::PowerLost => NorFlashErrorKind::Other,
        }
    }
}

impl<const PAGES: usize, const PAGE: usize> RamFlash<PAGES, PAGE> {
    /// Erased, powered, never cut.
    pub const ERASED: Self = Self {
        bytes: [[0xFF; PAGE]; PAGES],
        written: [[false; PAGE]; PAGES],
        cut_after: None,
        powered: true,
        words: 0,
        erases: [0; PAGES],
    };

    /// Makes this flash a copy of `other` (contents, wear and power), in place: no
    /// page-sized temporaries.
    pub fn copy_from(&mut self, other: &Self) {
        self.bytes.clone_from(&other.bytes);
        self.written.clone_from(&other.written);
        self.cut_after = other.cut_after;
        self.powered = other.powered;
        self.words = other.words;
        self.erases = other.erases;
    }

    /// Power back on (the contents are what the cut left).
    pub fn power_up(&mut self) {
        self.powered = true;
        self.cut_after = None;
    }

    /// One more word of work; `false` when the power goes now.
    fn tick(&mut self) -> bool {
        if !self.powered {
            return false;
        }
        self.words += 1;
        match self.cut_after.as_mut() {
            Some(0) => {
                self.powered = false;
                false
            }
            Some(n) => {
                *n -= 1;
                true
            }
            None => true,
        }
    }

    fn check(
        &self,
        offset: u32,
        len: usize,
        align: usize,
    ) -> Result<(usize, usize), RamFlashError> {
        let offset = offset as usize;
        if offset % align != 0 || len % align != 0 {
            return Err(RamFlashError::NotAligned);
        }
        if offset.checked_add(len).is_none_or(|end| end > PAGES * PAGE) {
            return Err(RamFlashError::OutOfBounds);
        }
        Ok((offset, len))
    }

    /// A half-done word: some of the bits the write would clear, chosen by the cut's place.
    fn torn(old: u8, new: u8, at: usize) -> u8 {
        let mask = (at as u8).wrapping_mul(0x9D) ^ 0x5A;
        old & (new | mask)
    }
}

impl<const PAGES: usize, const PAGE: usize> ErrorType for RamFlash<PAGES, PAGE> {
    type Error = RamFlashError;
}

// Every index below is inside `check`'s bounds (offset + len ≤ PAGES · PAGE, word-aligned).
#[allow(clippy::indexing_slicing)]
impl<const PAGES: usize, const PAGE: usize> ReadNorFlash for RamFlash<PAGES, PAGE> {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        if !self.powered {
            return Err(RamFlashError::PowerLost);
        }
        let (offset, len) = self.check(offset, bytes.len(), 1)?;
        for (i, b) in bytes.iter_mut().enumerate().take(len) {
            let at = offset + i;
            *b = self.bytes[at / PAGE][at % PAGE];
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        PAGES * PAGE
    }
}

#[allow(clippy::indexing_slicing)]
impl<const PAGES: usize, const PAGE: usize> NorFlash for RamFlash<PAGES, PAGE> {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if to < from {
            return Err(RamFlashError::OutOfBounds);
        }
        let (from, len) = self.check(from, (to - from) as usize, PAGE)?;
        for page in from / PAGE..(from + len) / PAGE {
            self.erases[page] += 1;
            for word in 0..PAGE / 4 {
                let at = word * 4;
                if !self.tick() {
                    // Power lost mid-erase: this word garbage, the rest as they were.
                    for b in &mut self.bytes[page][at..at + 4] {
                        *b = Self::torn(0xFF, *b ^ 0xA5, at);
                    }
                    return Err(RamFlashError::PowerLost);
                }
                self.bytes[page][at..at + 4].fill(0xFF);
                self.written[page][at..at + 4].fill(false);
            }
        }
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let (offset, len) = self.check(offset, bytes.len(), 4)?;
        if !self.powered {
            return Err(RamFlashError::PowerLost);
        }
        for word in 0..len / 4 {
            let at = offset + word * 4;
            let (page, within) = (at / PAGE, at % PAGE);
            if self.written[page][within] {
                return Err(RamFlashError::WrittenTwice);
            }
            let new = &bytes[word * 4..word * 4 + 4];
            if !self.tick() {
                for (i, &n) in new.iter().enumerate() {
                    let old = self.bytes[page][within + i];
                    self.bytes[page][within + i] = Self::torn(old, n, at + i);
                }
                self.written[page][within..within + 4].fill(true);
                return Err(RamFlashError::PowerLost);
            }
            for (i, &n) in new.iter().enumerate() {
                self.bytes[page][within + i] &= n;
            }
            self.written[page][within..within + 4].fill(true);
        }
        Ok(())
    }
}
