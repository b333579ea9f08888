//! One weak magnet as a health record stores it (bytes 78–79 and byte 7's upper bits of
//! [`super::HealthRecord`]'s layout). Units: depth and deviation in shares of the magnet's
//! flux, centre in radians of the rotor from the encoder's zero. O(1) each.

use crate::physics::magnets::WeakMagnet;

/// One weak magnet as a record stores it (version 5, bytes 78–79): its depth in 255ths of
/// the magnet's flux (0: none read) and its centre in 256ths of a revolution from the
/// encoder's zero (1.4°; a pole pitch is 45° on four pole pairs); from version 6 also its
/// depth's standard deviation in 512ths of the flux, rounded up (byte 7's bits 1–7: 1–127,
/// the largest 0.248; 0: not determined, or no magnet).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RecordedMagnet {
    pub(super) depth: u8,
    pub(super) centre: u8,
    pub(super) std: u8,
}

impl RecordedMagnet {
    /// No weak magnet read.
    pub const NONE: Self = Self {
        depth: 0,
        centre: 0,
        std: 0,
    };

    /// The same magnet with its depth's standard deviation `std` (share of its flux), rounded
    /// up to 1/512 and capped at 127/512; no deviation without a magnet or for a `std` that
    /// is not a finite non-negative number. O(1).
    #[must_use]
    pub fn with_std(mut self, std: f32) -> Self {
        self.std = if self.depth != 0 && std.is_finite() && std >= 0.0 {
            // Rounded up: −⌊−x⌋.
            let code = -crate::base::math::floor(-std * 512.0) as u32;
            code.clamp(1, 127) as u8
        } else {
            0
        };
        self
    }

    /// The depth's standard deviation as stored (share of the magnet's flux), `None` where
    /// none was (no magnet, not determined, or a record before version 6).
    pub fn std(&self) -> Option<f32> {
        (self.std != 0).then(|| f32::from(self.std) / 512.0)
    }

    /// `magnets` rounded to 1/255 of its flux (a depth that rounds to 0 is stored as 1/255:
    /// it was read) and 1/256 of a revolution. O(1).
    pub fn of(magnets: &WeakMagnet) -> Self {
        if magnets.is_none() {
            return Self::NONE;
        }
        let turns = magnets.centre / crate::base::math::TAU;
        let turns = turns - crate::base::math::floor(turns);
        Self {
            depth: ((magnets.depth * 255.0 + 0.5) as u8).max(1),
            centre: ((turns * 256.0 + 0.5) as u32 % 256) as u8,
            std: 0,
        }
    }

    /// The weak magnet as stored ([`WeakMagnet::NONE`]: none read).
    pub fn magnets(&self) -> WeakMagnet {
        if self.depth == 0 {
            return WeakMagnet::NONE;
        }
        WeakMagnet::new(
            f32::from(self.depth) / 255.0,
            crate::base::math::TAU * f32::from(self.centre) / 256.0,
        )
    }
}
