//! The flash interface (RM0090 §3.5–3.9) and the data sectors 5–11 behind it: unlock by
//! the two keys, sector erase (SER, SNB, STRT), programming (PG, PSIZE) of erased bits only
//! (NOR: a write can clear bits, never set them), the wait states in ACR. Erase and program
//! complete at once. Work per access: O(1), an erase O(sector).

/// The first data sector's address (sector 5) and the end of the 1 MiB array.
pub const DATA_START: u32 = 0x0802_0000;
pub const FLASH_END: u32 = 0x0810_0000;
const SECTOR_BYTES: u32 = 128 * 1024;

const ACR: u32 = 0x00;
const KEYR: u32 = 0x04;
const SR: u32 = 0x0C;
const CR: u32 = 0x10;
const OPTCR: u32 = 0x14;
const KEYS: [u32; 2] = [0x4567_0123, 0xCDEF_89AB];
const LOCK: u32 = 1 << 31;

/// Why a flash operation was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashFault {
    /// A key out of sequence: the interface stays locked until reset.
    KeySequence,
    /// An erase of a code sector (0–4) or past the array.
    EraseOutside { sector: u32 },
    /// A write to the array without PG, or while locked.
    WriteNotProgramming { address: u32 },
}

#[derive(Clone, Debug)]
pub struct FlashInterface {
    acr: u32,
    sr: u32,
    cr: u32,
    optcr: u32,
    keys_seen: usize,
    /// Sectors 5–11.
    data: Vec<u8>,
    pub faults: Vec<FlashFault>,
    pub erases: u32,
    pub programmed_bytes: u64,
    /// Times the interface was unlocked (one per write of a store).
    pub unlocks: u32,
}

impl FlashInterface {
    /// Erased data sectors.
    pub fn new() -> Self {
        Self {
            acr: 0,
            sr: 0,
            cr: LOCK,
            optcr: 0x0FFF_AAED,
            keys_seen: 0,
            data: vec![0xff; (FLASH_END - DATA_START) as usize],
            faults: Vec::new(),
            erases: 0,
            programmed_bytes: 0,
            unlocks: 0,
        }
    }

    /// Puts `bytes` at `address` (a pair's image from `host-sim flash-pair`), as a
    /// programmer would.
    pub fn load(&mut self, address: u32, bytes: &[u8]) -> anyhow::Result<()> {
        let start = address
            .checked_sub(DATA_START)
            .ok_or_else(|| anyhow::anyhow!("{address:#x} is below the data sectors"))?
            as usize;
        let slot = self
            .data
            .get_mut(start..start + bytes.len())
            .ok_or_else(|| {
                anyhow::anyhow!("{} bytes at {address:#x} pass the array's end", bytes.len())
            })?;
        slot.copy_from_slice(bytes);
        Ok(())
    }

    /// The array's bytes from `address`.
    pub fn bytes(&self, address: u32, len: usize) -> Option<&[u8]> {
        let start = address.checked_sub(DATA_START)? as usize;
        self.data.get(start..start + len)
    }

    /// Flash wait states (ACR.LATENCY).
    pub fn latency(&self) -> u32 {
        self.acr & 0xf
    }

    pub fn read_register(&self, offset: u32) -> Option<u32> {
        match offset {
            ACR => Some(self.acr),
            KEYR => Some(0),
            SR => Some(self.sr),
            CR => Some(self.cr),
            OPTCR => Some(self.optcr),
            0x08 => Some(0),
            _ => None,
        }
    }

    pub fn write_register(&mut self, offset: u32, value: u32) -> Option<()> {
        match offset {
            ACR => self.acr = value & 0x1f0f,
            KEYR => {
                if self.cr & LOCK == 0 {
                    // A key while unlocked is a sequence error too (RM0090 §3.5.1).
                    self.faults.push(FlashFault::KeySequence);
                } else if self.keys_seen < 2 && value == KEYS[self.keys_seen] {
                    self.keys_seen += 1;
                    if self.keys_seen == 2 {
                        self.cr &= !LOCK;
                        self.keys_seen = 0;
                        self.unlocks += 1;
                    }
                } else {
                    self.faults.push(FlashFault::KeySequence);
                    self.keys_seen = 2;
                }
            }
            // Flags are cleared by writing 1.
            SR => self.sr &= !(value & 0xf3),
            CR => {
                if self.cr & LOCK != 0 {
                    return Some(());
                }
                self.cr = value & 0x8301_037f;
                if self.cr & (1 << 16) != 0 {
                    self.start();
                    self.cr &= !(1 << 16);
                }
            }
            OPTCR | 0x08 => {}
            _ => return None,
        }
        Some(())
    }

    fn start(&mut self) {
        if self.cr & 2 != 0 {
            let sector = (self.cr >> 3) & 0xf;
            if !(5..=11).contains(&sector) {
                self.faults.push(FlashFault::EraseOutside { sector });
                return;
            }
            let at = ((sector - 5) * SECTOR_BYTES) as usize;
            self.data[at..at + SECTOR_BYTES as usize].fill(0xff);
            self.erases += 1;
            // EOP only with EOPIE.
            if self.cr & (1 << 24) != 0 {
                self.sr |= 1;
            }
        }
    }

    pub fn read_data(&self, address: u32, size: usize) -> u32 {
        let at = (address - DATA_START) as usize;
        let mut v = 0u32;
        for i in 0..size {
            v |= u32::from(self.data.get(at + i).copied().unwrap_or(0xff)) << (8 * i);
        }
        v
    }

    pub fn write_data(&mut self, address: u32, size: usize, value: u32) {
        if self.cr & LOCK != 0 || self.cr & 1 == 0 {
            self.faults
                .push(FlashFault::WriteNotProgramming { address });
            return;
        }
        let at = (address - DATA_START) as usize;
        for i in 0..size {
            if let Some(b) = self.data.get_mut(at + i) {
                *b &= (value >> (8 * i)) as u8;
            }
        }
        self.programmed_bytes += size as u64;
        if self.cr & (1 << 24) != 0 {
            self.sr |= 1;
        }
    }
}

impl Default for FlashInterface {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unlocked() -> FlashInterface {
        let mut f = FlashInterface::new();
        f.write_register(KEYR, KEYS[0]).unwrap();
        f.write_register(KEYR, KEYS[1]).unwrap();
        f
    }

    #[test]
    fn programming_needs_the_keys_and_pg_and_only_clears_bits() {
        let mut f = FlashInterface::new();
        f.write_data(DATA_START, 4, 0);
        assert_eq!(
            f.faults,
            [FlashFault::WriteNotProgramming {
                address: DATA_START
            }]
        );
        let mut f = unlocked();
        f.write_register(CR, 1 | (2 << 8)).unwrap();
        f.write_data(DATA_START, 4, 0x1234_5678);
        f.write_data(DATA_START, 4, 0xffff_0000);
        assert_eq!(f.read_data(DATA_START, 4), 0x1234_0000);
        assert!(f.faults.is_empty());
    }

    #[test]
    fn a_sector_erase_sets_its_bytes_and_refuses_code_sectors() {
        let mut f = unlocked();
        f.write_register(CR, 1).unwrap();
        f.write_data(DATA_START + SECTOR_BYTES, 1, 0);
        f.write_register(CR, 2 | (6 << 3) | (1 << 16)).unwrap();
        assert_eq!(f.read_data(DATA_START + SECTOR_BYTES, 1), 0xff);
        f.write_register(CR, 2 | (4 << 3) | (1 << 16)).unwrap();
        assert_eq!(f.faults, [FlashFault::EraseOutside { sector: 4 }]);
    }

    #[test]
    fn a_wrong_key_keeps_it_locked() {
        let mut f = FlashInterface::new();
        f.write_register(KEYR, KEYS[1]).unwrap();
        f.write_register(KEYR, KEYS[0]).unwrap();
        f.write_register(KEYR, KEYS[1]).unwrap();
        assert_ne!(f.read_register(CR).unwrap() & LOCK, 0);
    }
}
