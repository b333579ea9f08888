//! The GA's state as a fixed-size, versioned, checksummed byte record, so that a preflight
//! interrupted by a power loss resumes where its last checkpoint left it and finishes with
//! the same bits as an uninterrupted run. O(`P`) to write or read; no allocation.
//!
//! Layout (format version 2), all little-endian, `P` = population, `G` = genes (9):
//!
//! | offset | bytes | field |
//! | --- | --- | --- |
//! | 0 | 4 | magic `b"EMAG"` |
//! | 4 | 2 | format version `u16` = 2 |
//! | 6 | 2 | population `P` (`u16`) |
//! | 8 | 2 | genes per individual `G` (`u16`, 9) |
//! | 10 | 2 | reserved, 0 |
//! | 12 | 4 | run fingerprint `u32` (the caller's: measured test, settings, seed) |
//! | 16 | 16 | random generator state, 4 × `u32` |
//! | 32 | 4 | evaluations `u32` |
//! | 36 | 4 | generations `u32` |
//! | 40 | 4 | stall count `u32` |
//! | 44 | 4 | stall reference fitness `f32` |
//! | 48 | 2 | initial-population members evaluated `u16` |
//! | 50 | 1 | status: 0 running, 1 evaluation budget, 2 generation limit, 3 stalled |
//! | 51 | 1 | 1 if a candidate is pending, else 0 |
//! | 52 | 4·G | pending candidate's genes, `G` × `f32` (0 when none) |
//! | 52 + 4·G | 4·(G+1) | best individual: `G` genes + fitness |
//! | 56 + 8·G | 4·(G+1)·P | population, `G` genes + fitness per member |
//! | end − 4 | 4 | CRC-32 (IEEE) of every byte before it |
//!
//! Version 1 is the same layout with the paper's eight genes (`G` = 8), from before the
//! ninth fault: it is still resumed, each individual's demagnetization gene set to its
//! nominal value, which the monitor model plays bit for bit as the eight-gene model did, so
//! the stored fitnesses hold.
//!
//! The settings are not stored: they belong to the firmware image; the fingerprint (e.g.
//! [`crate::preflight::fdi::Identification::fingerprint`]) ties a record to one test, settings and seed.

use super::{Genes, Individual, Status, SteadyStateGa, StopReason, GENES};
use crate::base::random::Xoshiro128PlusPlus;
use crate::physics::fault::{FaultVector, PAPER_FAULT_COUNT};
use crate::test::trace::Crc32;

/// First four bytes of every GA record.
pub const RECORD_MAGIC: [u8; 4] = *b"EMAG";
/// The record format version this code writes (it resumes version 1 too).
pub const RECORD_VERSION: u16 = 2;

/// Bytes of the record of a GA with `population` members.
pub const fn record_bytes(population: usize) -> usize {
    record_bytes_of(GENES, population)
}

/// Bytes of a record of `genes` genes per individual and `population` members.
const fn record_bytes_of(genes: usize, population: usize) -> usize {
    HEAD_BYTES + 4 * genes + 4 * (genes + 1) * (population + 1) + 4
}

/// Bytes before the pending candidate's genes (magic … flags, the table above).
const HEAD_BYTES: usize = 52;

/// Genes per individual in a record of `version`.
fn genes_of(version: u16) -> Option<usize> {
    match version {
        1 => Some(PAPER_FAULT_COUNT),
        RECORD_VERSION => Some(GENES),
        _ => None,
    }
}

/// Why a record was refused. The GA it would have replaced is left as it was, so the
/// identification simply starts (or goes on) from there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RecordError {
    /// The buffer is not [`record_bytes`]`(P)` long.
    WrongLength {
        found: u32,
        expected: u32,
    },
    /// Not a GA record (erased flash reads `ff ff ff ff`).
    BadMagic,
    UnsupportedVersion {
        found: u16,
    },
    /// A record of another population size or gene count.
    WrongShape {
        population: u16,
        genes: u16,
    },
    /// The stored checksum differs from the computed one (a torn write, a flipped bit).
    BadChecksum {
        stored: u32,
        computed: u32,
    },
    /// A sound record of another run (another test, settings or seed).
    OtherRun {
        stored: u32,
        expected: u32,
    },
    /// Checksum right but contents impossible (NaN fitness, counters out of range): written
    /// by other code.
    Inconsistent,
}

/// Writes little-endian fields into a byte slice; out-of-range writes are dropped (the length
/// is checked before any write).
struct Writer<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn bytes(&mut self, b: &[u8]) {
        let end = self.at.saturating_add(b.len());
        if let Some(dst) = self.out.get_mut(self.at..end) {
            // Element by element: `copy_from_slice` keeps a length-mismatch panic, and with it
            // `core::fmt`, in the firmware image.
            for (d, s) in dst.iter_mut().zip(b) {
                *d = *s;
            }
        }
        self.at = end;
    }
    fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
    fn individual(&mut self, ind: &Individual) {
        for g in ind.genes {
            self.f32(g);
        }
        self.f32(ind.fitness);
    }
}

/// Reads little-endian fields; past the end it reads zeros (the length is checked first).
/// Individuals of `genes` stored genes; the genes a record does not store read nominal.
#[derive(Clone)]
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    genes: usize,
}

impl Reader<'_> {
    fn array<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        let end = self.at.saturating_add(N);
        if let Some(src) = self.bytes.get(self.at..end) {
            for (o, s) in out.iter_mut().zip(src) {
                *o = *s;
            }
        }
        self.at = end;
        out
    }
    fn u8(&mut self) -> u8 {
        let [b] = self.array::<1>();
        b
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.array())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.array())
    }
    fn f32(&mut self) -> f32 {
        f32::from_bits(self.u32())
    }
    fn genes(&mut self) -> Genes {
        let mut out = *FaultVector::NOMINAL.as_array();
        for g in out.iter_mut().take(self.genes) {
            *g = self.f32();
        }
        out
    }
    fn individual(&mut self) -> Individual {
        let genes = self.genes();
        Individual {
            genes,
            fitness: self.f32(),
        }
    }
}

fn status_code(status: Status) -> u8 {
    match status {
        Status::Running => 0,
        Status::Done(StopReason::EvaluationBudget) => 1,
        Status::Done(StopReason::GenerationLimit) => 2,
        Status::Done(StopReason::Stalled) => 3,
    }
}

fn status_from_code(code: u8) -> Option<Status> {
    Some(match code {
        0 => Status::Running,
        1 => Status::Done(StopReason::EvaluationBudget),
        2 => Status::Done(StopReason::GenerationLimit),
        3 => Status::Done(StopReason::Stalled),
        _ => return None,
    })
}

fn crc(bytes: &[u8]) -> u32 {
    let mut c = Crc32::new();
    c.update(bytes);
    c.finish()
}

fn check_length(len: usize, expected: usize) -> Result<(), RecordError> {
    if len == expected {
        Ok(())
    } else {
        Err(RecordError::WrongLength {
            found: u32::try_from(len).unwrap_or(u32::MAX),
            expected: u32::try_from(expected).unwrap_or(u32::MAX),
        })
    }
}

impl<const P: usize> SteadyStateGa<P> {
    /// Bytes of this GA's record.
    pub const RECORD_BYTES: usize = record_bytes(P);

    /// Writes the whole state into `out` ([`Self::RECORD_BYTES`] long), tagged with the
    /// caller's run `fingerprint`. O(P).
    /// A run of fewer members than `P` ([`SteadyStateGa::restart_with`]) is refused
    /// ([`RecordError::WrongShape`]).
    pub fn save(&self, fingerprint: u32, out: &mut [u8]) -> Result<(), RecordError> {
        check_length(out.len(), record_bytes(P))?;
        self.whole()?;
        let mut w = Writer { out, at: 0 };
        w.bytes(&RECORD_MAGIC);
        w.u16(RECORD_VERSION);
        w.u16(P as u16);
        w.u16(GENES as u16);
        w.u16(0);
        w.u32(fingerprint);
        for word in self.rng.state() {
            w.u32(word);
        }
        w.u32(self.evaluations);
        w.u32(self.generations);
        w.u32(self.stall.generations);
        w.f32(self.stall.reference);
        w.u16(self.filled);
        w.bytes(&[status_code(self.status), u8::from(self.pending.is_some())]);
        for g in self.pending.unwrap_or([0.0; GENES]) {
            w.f32(g);
        }
        w.individual(&self.best);
        for ind in &self.population {
            w.individual(ind);
        }
        let body = w.at;
        let sum = crc(w.out.get(..body).unwrap_or(&[]));
        w.u32(sum);
        Ok(())
    }

    /// The GA stored in `record`, run with `settings`, if the record is sound and belongs to
    /// the run `fingerprint`. O(P). On `Err` nothing is changed anywhere: start afresh.
    pub fn restore(
        settings: super::GaSettings,
        fingerprint: u32,
        record: &[u8],
    ) -> Result<Self, RecordError> {
        let mut ga = Self::new(settings, 0).map_err(|_| RecordError::Inconsistent)?;
        ga.resume_from(fingerprint, record)?;
        Ok(ga)
    }

    /// This GA, with its own settings, continued in place from `record` if the record is
    /// sound and belongs to the run `fingerprint`; on `Err` it is left exactly as it was.
    /// O(P), two passes over the record (checked, then loaded), no copy of the GA: on the
    /// controller it needs no more stack than a few fields.
    pub fn resume_from(&mut self, fingerprint: u32, record: &[u8]) -> Result<(), RecordError> {
        self.whole()?;
        let state = open_record::<P>(fingerprint, record)?;
        if !state_sound::<P>(state.clone()) {
            return Err(RecordError::Inconsistent);
        }
        self.load(state);
        Ok(())
    }

    /// `Ok` if the run holds all `P` members (a record's shape).
    fn whole(&self) -> Result<(), RecordError> {
        if self.members() == P {
            Ok(())
        } else {
            Err(RecordError::WrongShape {
                population: self.members,
                genes: GENES as u16,
            })
        }
    }

    /// Loads the state at `r` (checked by [`state_sound`]).
    fn load(&mut self, mut r: Reader) {
        let rng = [r.u32(), r.u32(), r.u32(), r.u32()];
        if let Some(rng) = Xoshiro128PlusPlus::from_state(rng) {
            self.rng = rng;
        }
        self.evaluations = r.u32();
        self.generations = r.u32();
        self.stall.generations = r.u32();
        self.stall.reference = r.f32();
        self.filled = r.u16();
        self.status = status_from_code(r.u8()).unwrap_or(Status::Running);
        let has_pending = r.u8();
        let pending = r.genes();
        self.pending = (has_pending == 1).then_some(pending);
        self.best = r.individual();
        for ind in self.population.iter_mut() {
            *ind = r.individual();
        }
    }
}

/// `record` (a current record of `P` members) as a controller before the ninth fault wrote
/// it: version 1, the paper's eight genes per individual (the ninth dropped), its own CRC-32,
/// into the start of `out`; returns its length. For tests and tools that make old
/// checkpoints. O(P).
pub fn as_version_1<const P: usize>(record: &[u8], out: &mut [u8]) -> Result<usize, RecordError> {
    check_length(record.len(), record_bytes(P))?;
    let len = record_bytes_of(PAPER_FAULT_COUNT, P);
    let Some(out) = out.get_mut(..len) else {
        return Err(RecordError::WrongLength {
            found: u32::try_from(out.len()).unwrap_or(u32::MAX),
            expected: u32::try_from(len).unwrap_or(u32::MAX),
        });
    };
    let mut w = Writer { out, at: 0 };
    let mut r = Reader {
        bytes: record,
        at: 0,
        genes: GENES,
    };
    let head = r.array::<HEAD_BYTES>();
    w.bytes(&head);
    w.at = 4;
    w.u16(1);
    w.at = 8;
    w.u16(PAPER_FAULT_COUNT as u16);
    w.at = HEAD_BYTES;
    // Pending genes, then the best and every member with its fitness.
    let pending = r.genes();
    for g in pending.iter().take(PAPER_FAULT_COUNT) {
        w.f32(*g);
    }
    for _ in 0..=P {
        let ind = r.individual();
        for g in ind.genes.iter().take(PAPER_FAULT_COUNT) {
            w.f32(*g);
        }
        w.f32(ind.fitness);
    }
    let body = w.at;
    let sum = crc(w.out.get(..body).unwrap_or(&[]));
    w.u32(sum);
    Ok(len)
}

/// The reader at the GA state of `record` (offset 16), if `record` is a whole, undamaged
/// record of this format and shape for the run `fingerprint`.
fn open_record<const P: usize>(fingerprint: u32, record: &[u8]) -> Result<Reader<'_>, RecordError> {
    let mut r = Reader {
        bytes: record,
        at: 0,
        genes: 0,
    };
    let (magic, version) = (r.array::<4>(), r.u16());
    // A record too short for its header is a wrong length, whatever its first bytes.
    let stored_genes = genes_of(version).unwrap_or(GENES);
    check_length(record.len(), record_bytes_of(stored_genes, P))?;
    if magic != RECORD_MAGIC {
        return Err(RecordError::BadMagic);
    }
    if genes_of(version).is_none() {
        return Err(RecordError::UnsupportedVersion { found: version });
    }
    let (population, genes) = (r.u16(), r.u16());
    if usize::from(population) != P || usize::from(genes) != stored_genes {
        return Err(RecordError::WrongShape { population, genes });
    }
    r.genes = stored_genes;
    let body = record.len().saturating_sub(4);
    let (head, trailer) = record.split_at(body);
    let stored_sum = Reader {
        bytes: trailer,
        at: 0,
        genes: 0,
    }
    .u32();
    let computed = crc(head);
    if stored_sum != computed {
        return Err(RecordError::BadChecksum {
            stored: stored_sum,
            computed,
        });
    }
    let _reserved = r.u16();
    let stored = r.u32();
    if stored != fingerprint {
        return Err(RecordError::OtherRun {
            stored,
            expected: fingerprint,
        });
    }
    Ok(r)
}

/// Whether the GA state at `r` is one a GA can be in: a random generator that is not all
/// zeros, a known status, a pending flag of 0 or 1, genes within [0, 1], no NaN fitness, at
/// most `P` members evaluated. Reads one individual at a time.
fn state_sound<const P: usize>(mut r: Reader) -> bool {
    let genes_sound = |g: &Genes| g.iter().all(|x| (0.0..=1.0).contains(x));
    let individual_sound = |ind: Individual| !ind.fitness.is_nan() && genes_sound(&ind.genes);
    let rng = [r.u32(), r.u32(), r.u32(), r.u32()];
    let _counts = [r.u32(), r.u32(), r.u32()];
    let stall_reference = r.f32();
    let filled = r.u16();
    let status = r.u8();
    let has_pending = r.u8();
    let pending = r.genes();
    Xoshiro128PlusPlus::from_state(rng).is_some()
        && !stall_reference.is_nan()
        && usize::from(filled) <= P
        && status_from_code(status).is_some()
        && match has_pending {
            0 => true,
            1 => genes_sound(&pending),
            _ => false,
        }
        && (0..=P).all(|_| individual_sound(r.individual()))
}
