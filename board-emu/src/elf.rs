//! The board image as an ELF32 (little-endian ARM) file: its loadable segments at their load
//! addresses and its symbol table. Only what the emulator needs; every offset is checked.

use anyhow::{bail, ensure, Context, Result};

/// One loadable segment: `bytes` to place at `address` (its load address: `.data`'s initial
/// values sit in flash), `memory` bytes in all (the rest zero).
#[derive(Clone, Debug)]
pub struct Segment {
    pub address: u32,
    pub bytes: Vec<u8>,
    pub memory: u32,
}

/// A symbol's address and size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Symbol {
    pub address: u32,
    pub size: u32,
}

#[derive(Clone, Debug)]
pub struct Image {
    pub segments: Vec<Segment>,
    symbols: Vec<(String, Symbol)>,
}

fn u16_at(b: &[u8], at: usize) -> Result<u16> {
    let s = b.get(at..at + 2).context("ELF: truncated")?;
    Ok(u16::from_le_bytes([s[0], s[1]]))
}

fn u32_at(b: &[u8], at: usize) -> Result<u32> {
    let s = b.get(at..at + 4).context("ELF: truncated")?;
    Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

fn c_string(b: &[u8], at: usize) -> Option<&str> {
    let rest = b.get(at..)?;
    let end = rest.iter().position(|&c| c == 0)?;
    std::str::from_utf8(&rest[..end]).ok()
}

const PT_LOAD: u32 = 1;
const SHT_SYMTAB: u32 = 2;
const EM_ARM: u16 = 40;

impl Image {
    pub fn parse(b: &[u8]) -> Result<Self> {
        ensure!(b.get(..4) == Some(b"\x7fELF"), "not an ELF file");
        ensure!(
            b.get(4) == Some(&1) && b.get(5) == Some(&1),
            "not a 32-bit little-endian ELF"
        );
        ensure!(u16_at(b, 0x12)? == EM_ARM, "not an ARM ELF");
        let (phoff, phentsize, phnum) = (
            u32_at(b, 0x1c)? as usize,
            u16_at(b, 0x2a)? as usize,
            u16_at(b, 0x2c)? as usize,
        );
        let mut segments = Vec::new();
        for i in 0..phnum {
            let h = phoff + i * phentsize;
            if u32_at(b, h)? != PT_LOAD {
                continue;
            }
            let (offset, paddr, filesz, memsz) = (
                u32_at(b, h + 4)? as usize,
                u32_at(b, h + 12)?,
                u32_at(b, h + 16)? as usize,
                u32_at(b, h + 20)?,
            );
            let bytes = b
                .get(offset..offset + filesz)
                .context("ELF: a segment past the file's end")?
                .to_vec();
            if filesz == 0 && memsz == 0 {
                continue;
            }
            segments.push(Segment {
                address: paddr,
                bytes,
                memory: memsz,
            });
        }
        let (shoff, shentsize, shnum) = (
            u32_at(b, 0x20)? as usize,
            u16_at(b, 0x2e)? as usize,
            u16_at(b, 0x30)? as usize,
        );
        let mut symbols = Vec::new();
        for i in 0..shnum {
            let h = shoff + i * shentsize;
            if u32_at(b, h + 4)? != SHT_SYMTAB {
                continue;
            }
            let (offset, size, link, entsize) = (
                u32_at(b, h + 16)? as usize,
                u32_at(b, h + 20)? as usize,
                u32_at(b, h + 24)? as usize,
                u32_at(b, h + 36)? as usize,
            );
            let strings = shoff + link * shentsize;
            let str_offset = u32_at(b, strings + 16)? as usize;
            if entsize == 0 {
                bail!("ELF: a symbol table of zero-sized entries");
            }
            for s in 0..size / entsize {
                let e = offset + s * entsize;
                let name = u32_at(b, e)? as usize;
                let (address, size) = (u32_at(b, e + 4)?, u32_at(b, e + 8)?);
                if let Some(n) = c_string(b, str_offset + name) {
                    if !n.is_empty() {
                        symbols.push((n.to_string(), Symbol { address, size }));
                    }
                }
            }
        }
        Ok(Self { segments, symbols })
    }

    /// The symbol named exactly `name`.
    pub fn symbol(&self, name: &str) -> Option<Symbol> {
        self.symbols
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, s)| *s)
    }

    /// The first symbol whose (mangled) name contains `part`.
    pub fn symbol_containing(&self, part: &str) -> Option<Symbol> {
        self.symbols
            .iter()
            .find(|(n, _)| n.contains(part))
            .map(|(_, s)| *s)
    }
}
