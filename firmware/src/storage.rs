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
//! * [`AbStore`]: the compact store the board uses (`sequential-storage` adds ≈ 17 kB to
//!   an image that has 64 KiB in all; README, "Records in flash"): the newest of a sequence
//!   of items in an A/B pair of pages, appended with a commit word, one pair each for the
//!   actuator record, the checkpoint and the health log's whole image.
//!
//! Generic over any `embedded-storage-async` [`NorFlash`]: the board's sectors, or a
//! RAM-backed flash ([`RamFlash`]) under emulation and in the host's power-cut tests. Every
//! call is one bounded flash operation sequence: O(items in the range) reads without a cache
//! (uncached), at most one page erase per store. No allocation; the caller lends the item
//! buffer.

use core::ops::Range;

use embedded_storage::nor_flash as blocking;
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

    /// The two halves of a store's range: the pages of an [`AbStore`] pair (one sector each
    /// on the STM32F405) [byte offsets].
    pub fn pair(range: &Range<u32>) -> (u32, u32) {
        let half = (range.end.saturating_sub(range.start)) / 2;
        (range.start, range.start + half)
    }
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

/// The newest of a sequence of items (the actuator record, the GA checkpoint, the health
/// log's image) in an A/B pair of erase pages, for a controller whose flash cannot hold a
/// general store. Items are appended to the page holding the newest one, each as a header
/// (magic, sequence, length), the item, its CRC-32 and last a commit word (the CRC's
/// complement), so that a cut anywhere leaves that entry unsound and the older ones
/// standing. When the page is full (or its free space is not cleanly erased) the other page
/// is erased and the item goes there: a page is erased only while the other one holds the
/// newest item, and once per page-full of items (wear). A read takes the sound entry with the
/// highest sequence.
///
/// Work: a scan reads both pages' entries in 64-byte chunks, O(page); a write adds one item
/// and at most one page erase. No allocation: items are written from the caller's bytes
/// and read into the caller's buffer.
pub struct AbStore<F: blocking::NorFlash> {
    flash: F,
    pages: [u32; 2],
}

/// First word of an [`AbStore`] entry.
const AB_MAGIC: u32 = u32::from_le_bytes(*b"EMAB");
/// Header bytes before the item.
const AB_HEADER: u32 = 12;
/// CRC and commit word after the item.
const AB_TRAILER: u32 = 8;
/// Bytes read at once while checking an entry.
const AB_CHUNK: usize = 64;

/// Why an [`AbStore`] operation failed.
#[derive(Debug, PartialEq)]
pub enum AbError<E> {
    /// The two pages are not distinct whole erase pages, or the flash writes in units that
    /// do not divide a 4-byte word.
    Layout,
    /// The item does not fit a page, or the read's destination does not hold the item.
    TooLarge,
    /// The flash failed (a power cut mid-operation ends here).
    Flash(E),
}

/// What one position of a page holds.
enum AbSlot {
    /// Erased header: the page's free space starts here.
    Erased,
    /// Neither erased nor a header: the page takes no more entries.
    Garbage,
    /// An entry (sound if its CRC and commit word are whole) and where the next one starts.
    Entry {
        sequence: u32,
        len: u32,
        sound: bool,
        next: u32,
    },
}

/// The newest sound entry, and where each page's free space starts (`None`: the page takes
/// no more entries).
type AbScan = (Option<AbNewest>, [Option<u32>; 2]);

/// The newest sound entry: page index, offset, sequence, length.
#[derive(Clone, Copy)]
struct AbNewest {
    page: usize,
    at: u32,
    sequence: u32,
    len: u32,
}

impl<F: blocking::NorFlash> AbStore<F> {
    /// The pair of pages starting at `a` and `b` [byte offsets].
    pub fn new(flash: F, a: u32, b: u32) -> Result<Self, AbError<F::Error>> {
        let page = F::ERASE_SIZE as u32;
        let fits = |x: u32| {
            x % page == 0
                && (x as usize)
                    .checked_add(F::ERASE_SIZE)
                    .is_some_and(|end| end <= flash.capacity())
        };
        // Entries are laid out in 4-byte words.
        if a == b || !fits(a) || !fits(b) || F::WRITE_SIZE == 0 || 4 % F::WRITE_SIZE != 0 {
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

    /// The largest item a page takes [bytes].
    pub fn capacity(&self) -> usize {
        F::ERASE_SIZE.saturating_sub((AB_HEADER + AB_TRAILER) as usize)
    }

    /// Reads `len` bytes from `at` in chunks, handing each to `each` until it says stop;
    /// whether every chunk was taken.
    fn chunks(
        &mut self,
        at: u32,
        len: u32,
        mut each: impl FnMut(&[u8]) -> bool,
    ) -> Result<bool, AbError<F::Error>> {
        let mut chunk = [0u8; AB_CHUNK];
        let mut done = 0;
        while done < len {
            let n = (len - done).min(AB_CHUNK as u32);
            let part = chunk.get_mut(..n as usize).unwrap_or(&mut []);
            self.flash.read(at + done, part).map_err(AbError::Flash)?;
            if !each(part) {
                return Ok(false);
            }
            done += n;
        }
        Ok(true)
    }

    /// The CRC-32 of `len` bytes at `at` after `head`.
    fn crc(&mut self, head: &[u8], at: u32, len: u32) -> Result<u32, AbError<F::Error>> {
        let mut crc = shared::trace::Crc32::new();
        crc.update(head);
        self.chunks(at, len, |part| {
            crc.update(part);
            true
        })?;
        Ok(crc.finish())
    }

    /// Whether `len` bytes from `at` read erased (0xFF).
    fn erased(&mut self, at: u32, len: u32) -> Result<bool, AbError<F::Error>> {
        self.chunks(at, len, |part| part.iter().all(|&b| b == 0xFF))
    }

    /// What the page ending at `end` holds at `at`.
    fn slot(&mut self, at: u32, end: u32) -> Result<AbSlot, AbError<F::Error>> {
        if end.saturating_sub(at) < AB_HEADER + AB_TRAILER {
            return Ok(AbSlot::Garbage);
        }
        let mut head = [0u8; AB_HEADER as usize];
        self.flash.read(at, &mut head).map_err(AbError::Flash)?;
        if head.iter().all(|&b| b == 0xFF) {
            return Ok(AbSlot::Erased);
        }
        let [m0, m1, m2, m3, s0, s1, s2, s3, l0, l1, l2, l3] = head;
        let (magic, sequence, len) = (
            u32::from_le_bytes([m0, m1, m2, m3]),
            u32::from_le_bytes([s0, s1, s2, s3]),
            u32::from_le_bytes([l0, l1, l2, l3]),
        );
        // A damaged length may be anything: rounded up without overflow, then bounded.
        let room = end - at - AB_HEADER - AB_TRAILER;
        let Some(padded) = len.checked_next_multiple_of(4).filter(|&p| p <= room) else {
            return Ok(AbSlot::Garbage);
        };
        if magic != AB_MAGIC {
            return Ok(AbSlot::Garbage);
        }
        let sum = self.crc(&head, at + AB_HEADER, padded)?;
        let mut tail = [0u8; AB_TRAILER as usize];
        self.flash
            .read(at + AB_HEADER + padded, &mut tail)
            .map_err(AbError::Flash)?;
        let [c0, c1, c2, c3, k0, k1, k2, k3] = tail;
        let sound = u32::from_le_bytes([c0, c1, c2, c3]) == sum
            && u32::from_le_bytes([k0, k1, k2, k3]) == !sum;
        Ok(AbSlot::Entry {
            sequence,
            len,
            sound,
            next: at + AB_HEADER + padded + AB_TRAILER,
        })
    }

    /// The newest sound entry, and where each page's free space starts (`None`: the page
    /// takes no more entries).
    fn scan(&mut self) -> Result<AbScan, AbError<F::Error>> {
        let mut newest: Option<AbNewest> = None;
        let mut free = [None; 2];
        for (page, (start, free)) in self.pages.into_iter().zip(&mut free).enumerate() {
            let end = start + F::ERASE_SIZE as u32;
            let mut at = start;
            // Each entry takes at least header and trailer: the walk ends within the page.
            while at < end {
                match self.slot(at, end)? {
                    AbSlot::Erased => {
                        *free = Some(at);
                        break;
                    }
                    AbSlot::Garbage => break,
                    AbSlot::Entry {
                        sequence,
                        len,
                        sound,
                        next,
                    } => {
                        let newer =
                            newest.is_none_or(|n| sequence.wrapping_sub(n.sequence) as i32 > 0);
                        if sound && newer {
                            newest = Some(AbNewest {
                                page,
                                at,
                                sequence,
                                len,
                            });
                        }
                        at = next;
                    }
                }
            }
        }
        Ok((newest, free))
    }

    /// The newest item stored whole, read into the start of `out`: its length, or `None`
    /// when nothing is stored. `out` must hold the item.
    pub fn read(&mut self, out: &mut [u8]) -> Result<Option<usize>, AbError<F::Error>> {
        let (Some(n), _) = self.scan()? else {
            return Ok(None);
        };
        let item = out.get_mut(..n.len as usize).ok_or(AbError::TooLarge)?;
        self.flash
            .read(n.at + AB_HEADER, item)
            .map_err(AbError::Flash)?;
        Ok(Some(item.len()))
    }

    /// Appends `item` as the newest, written straight from `item` (its last partial word
    /// padded with zeros).
    pub fn write(&mut self, item: &[u8]) -> Result<(), AbError<F::Error>> {
        let Some(padded) = item
            .len()
            .checked_next_multiple_of(4)
            .filter(|&p| p <= self.capacity())
        else {
            return Err(AbError::TooLarge);
        };
        let need = AB_HEADER + padded as u32 + AB_TRAILER;
        let (newest, free) = self.scan()?;
        // The page of the newest item, if its free space takes this one and reads erased;
        // otherwise the other page, erased (the first page when nothing is stored).
        let current = newest.map_or(0, |n| n.page);
        let end = |page: usize| self.pages.get(page).map_or(0, |s| s + F::ERASE_SIZE as u32);
        let mut target = None;
        if let Some(at) = free.get(current).copied().flatten() {
            if at.saturating_add(need) <= end(current) && self.erased(at, need)? {
                target = Some(at);
            }
        }
        let at = match target {
            Some(at) => at,
            None => {
                let other = if newest.is_some() {
                    1 - current
                } else {
                    current
                };
                let start = self.pages.get(other).copied().unwrap_or(0);
                self.flash
                    .erase(start, start + F::ERASE_SIZE as u32)
                    .map_err(AbError::Flash)?;
                start
            }
        };
        let sequence = newest.map_or(0, |n| n.sequence.wrapping_add(1));
        let mut head = [0u8; AB_HEADER as usize];
        for (slot, word) in head
            .chunks_exact_mut(4)
            .zip([AB_MAGIC, sequence, item.len() as u32])
        {
            // Element by element: `copy_from_slice` keeps a length-mismatch panic, and with
            // it `core::fmt`, in the board image.
            for (d, s) in slot.iter_mut().zip(word.to_le_bytes()) {
                *d = s;
            }
        }
        let whole = item.len() - item.len() % 4;
        let (words, rest) = item.split_at(whole);
        let mut last = [0u8; 4];
        for (d, s) in last.iter_mut().zip(rest) {
            *d = *s;
        }
        let last = last.get(..padded - whole).unwrap_or(&[]);
        let mut crc = shared::trace::Crc32::new();
        crc.update(&head);
        crc.update(words);
        crc.update(last);
        let sum = crc.finish();
        self.flash.write(at, &head).map_err(AbError::Flash)?;
        self.flash
            .write(at + AB_HEADER, words)
            .map_err(AbError::Flash)?;
        self.flash
            .write(at + AB_HEADER + whole as u32, last)
            .map_err(AbError::Flash)?;
        let tail = at + AB_HEADER + padded as u32;
        self.flash
            .write(tail, &sum.to_le_bytes())
            .map_err(AbError::Flash)?;
        // Last: the commit word. Until it is whole the entry reads as unsound.
        self.flash
            .write(tail + 4, &(!sum).to_le_bytes())
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
    /// Pages of whole words: every index and division below relies on it (checked when
    /// [`RamFlash::ERASED`] is built, at compile time).
    const WHOLE_WORDS: () = assert!(PAGE >= 4 && PAGE % 4 == 0, "RamFlash pages are whole words");

    /// Erased, powered, never cut.
    pub const ERASED: Self = {
        let () = Self::WHOLE_WORDS;
        Self::BLANK
    };

    const BLANK: Self = Self {
        bytes: [[0xFF; PAGE]; PAGES],
        written: [[false; PAGE]; PAGES],
        cut_after: None,
        powered: true,
        words: 0,
        erases: [0; PAGES],
    };

    /// The flash's bytes, page after page (an image to write to a real flash).
    pub fn bytes(&self) -> &[u8] {
        self.bytes.as_flattened()
    }

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
impl<const PAGES: usize, const PAGE: usize> blocking::ReadNorFlash for RamFlash<PAGES, PAGE> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
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
impl<const PAGES: usize, const PAGE: usize> blocking::NorFlash for RamFlash<PAGES, PAGE> {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
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

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
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

/// The same flash through the async interface (`sequential-storage`'s stores take it).
impl<const PAGES: usize, const PAGE: usize> ReadNorFlash for RamFlash<PAGES, PAGE> {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        blocking::ReadNorFlash::read(self, offset, bytes)
    }

    fn capacity(&self) -> usize {
        PAGES * PAGE
    }
}

impl<const PAGES: usize, const PAGE: usize> NorFlash for RamFlash<PAGES, PAGE> {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        blocking::NorFlash::erase(self, from, to)
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        blocking::NorFlash::write(self, offset, bytes)
    }
}
