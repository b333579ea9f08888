//! The grease read from the chirp (issue 34): a least-squares fit of the motor's torque
//! balance over the chirp, accumulated frame by frame while the test is measured, that tells
//! the grease's viscous drag from its dry friction. A grease's drag follows its base oil's
//! viscosity, which wear does not change: it is a thermometer of the gearbox that the winding
//! thermistor is not (docs/identifiability.md §0c).
//!
//! Over blocks of [`BLOCK`] samples in which the motor turns one way (no stop, no reversal),
//! in equivalent current \[A\], motor angle θ_m and user angle θ_u \[rad\], one sample per
//! control period:
//!
//! `ī = a·Δω_m + c·sgn ω_m + b·Δθ_m + s·θ̄_u + u·Δω_u + o`
//!
//! with speeds as central differences [rad per sample] and every difference taken across the
//! block: motor inertia, dry friction, viscous drag, the load's spring, the user inertia, an
//! offset. `b` is every viscous torque the motor sees; only its ratio to the calibration
//! day's is used, so the units (per block, per sample) cancel. Work: O(1) per frame, 27
//! multiply-adds per block in f32 (over the grease study it reads the same to three decimals
//! as in f64), O(9³) once to solve in f64 (`crate::base::math::invert`); state 27 `f32` and a few
//! words (156 B); no allocation, no panic.

use crate::base::math::{invert, INVERT_N};

/// Samples per block (2 ms at 10 kHz).
pub const BLOCK: u32 = 20;
const _: () = assert!(BLOCK < 256);
/// Fewest one-way blocks the fit accepts (a 0.5 s chirp has ≈ 240 of its 250).
pub const MIN_BLOCKS: u16 = 24;

const UNKNOWNS: usize = 6;
/// Entries of the upper triangle of the normal matrix.
const PACKED: usize = UNKNOWNS * (UNKNOWNS + 1) / 2;

/// What the chirp's torque balance read.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GreaseReading {
    /// Viscous drag the motor sees [A of equivalent current per rad per block].
    pub viscous: f32,
    /// Dry friction [A of equivalent current].
    pub coulomb: f32,
    /// One-way blocks fitted.
    pub blocks: u16,
}

/// Why the chirp gave no reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GreaseError {
    /// Fewer one-way blocks than [`MIN_BLOCKS`] (a chirp too short or a motor that hardly
    /// moved).
    TooFewBlocks { have: u16, need: u16 },
    /// The blocks do not separate the six terms (e.g. the motor never turned both ways).
    Singular,
}

/// The streaming fit: fed the chirp's frames in order ([`push`](Self::push)), read at the end
/// ([`reading`](Self::reading)).
#[derive(Clone, Debug, PartialEq)]
pub struct ChirpTorqueFit {
    /// Upper triangle of Σ x·xᵀ, row by row.
    normal: [f32; PACKED],
    /// Σ x·y.
    rhs: [f32; UNKNOWNS],
    /// Motor and user angles of the two previous frames (newest first).
    motor: [f32; 2],
    user: [f32; 2],
    /// Current of the previous frame (the point whose speeds the next frame completes).
    current: f32,
    /// Frames pushed, counted up to 2 (the first point has speeds at the third frame); 3 once
    /// a block is open.
    frames: u8,
    /// The point's place in its block (0 opens a block).
    phase: u8,
    /// The open block: motor speed, user speed and motor angle at its start; sums of its
    /// current and user angle; the way the motor turned in it (+1, −1, 0 once it changed or
    /// stopped).
    start: [f32; 3],
    sum_current: f32,
    sum_user: f32,
    way: i8,
    blocks: u16,
}

impl ChirpTorqueFit {
    /// Nothing fitted: every byte zero, so that a `static` holding it lives in `.bss`.
    pub const ZERO: Self = Self {
        normal: [0.0; PACKED],
        rhs: [0.0; UNKNOWNS],
        motor: [0.0; 2],
        user: [0.0; 2],
        current: 0.0,
        frames: 0,
        phase: 0,
        start: [0.0; 3],
        sum_current: 0.0,
        sum_user: 0.0,
        way: 0,
        blocks: 0,
    };

    /// One chirp frame: equivalent current \[A\], motor and user angles \[rad\]. O(1); a block's
    /// 27 multiply-adds every [`BLOCK`] frames.
    pub fn push(&mut self, current: f32, motor_angle: f32, user_angle: f32) {
        if self.frames >= 2 {
            // The previous frame is now a point with speeds (central differences); the first
            // point (frame 1) opens the first block, every BLOCK-th after it the next.
            let motor_speed = 0.5 * (motor_angle - self.motor[1]);
            let user_speed = 0.5 * (user_angle - self.user[1]);
            if self.phase == 0 {
                if self.frames > 2 {
                    self.close_block(motor_speed, user_speed, self.motor[0]);
                }
                self.frames = 3;
                self.start = [motor_speed, user_speed, self.motor[0]];
                self.sum_current = 0.0;
                self.sum_user = 0.0;
                self.way = if motor_speed > 0.0 { 1 } else { -1 };
            }
            if motor_speed * f32::from(self.way) <= 0.0 {
                self.way = 0;
            }
            self.sum_current += self.current;
            self.sum_user += self.user[0];
            self.phase = (self.phase + 1) % BLOCK as u8;
        } else {
            self.frames += 1;
        }
        self.motor = [motor_angle, self.motor[0]];
        self.user = [user_angle, self.user[0]];
        self.current = current;
    }

    /// Adds the open block, ended at motor speed `motor_speed`, user speed `user_speed` and
    /// motor angle `motor_angle`, if the motor turned one way all through it.
    fn close_block(&mut self, motor_speed: f32, user_speed: f32, motor_angle: f32) {
        if self.way == 0 {
            return;
        }
        let n = BLOCK as f32;
        let [w0, u0, m0] = self.start;
        let x: [f32; UNKNOWNS] = [
            motor_speed - w0,
            f32::from(self.way),
            motor_angle - m0,
            self.sum_user / n,
            user_speed - u0,
            1.0,
        ];
        let y = self.sum_current / n;
        let mut k = 0;
        for (i, xi) in x.iter().enumerate() {
            if let Some(r) = self.rhs.get_mut(i) {
                *r += xi * y;
            }
            for xj in x.iter().skip(i) {
                if let Some(m) = self.normal.get_mut(k) {
                    *m += xi * xj;
                }
                k += 1;
            }
        }
        self.blocks = self.blocks.saturating_add(1);
    }

    /// One-way blocks fitted so far.
    pub fn blocks(&self) -> u16 {
        self.blocks
    }

    /// The fit's viscous drag and dry friction. O(9³): the normal equations inverted in
    /// f64 (`crate::base::math::invert`, padded to its 9×9 with an identity block).
    pub fn reading(&self) -> Result<GreaseReading, GreaseError> {
        let m = self.normal_matrix()?;
        self.solved(&invert(&m).ok_or(GreaseError::Singular)?)
    }

    /// [`reading`](Self::reading) in steps, for a controller's idle time, the same pieces:
    /// the normal matrix, its inverse ([`invert_stepwise`](crate::base::math::invert_stepwise))
    /// and the solve each in polls of their own. The same reading.
    pub async fn reading_stepwise(&self) -> Result<GreaseReading, GreaseError> {
        let m = self.normal_matrix()?;
        let inverse = crate::base::math::invert_stepwise(&m)
            .await
            .ok_or(GreaseError::Singular)?;
        crate::base::steps::pause().await;
        self.solved(&inverse)
    }

    /// The normal equations, padded to [`INVERT_N`] with an identity block; `Err` with too
    /// few blocks.
    fn normal_matrix(&self) -> Result<[[f64; INVERT_N]; INVERT_N], GreaseError> {
        if self.blocks < MIN_BLOCKS {
            return Err(GreaseError::TooFewBlocks {
                have: self.blocks,
                need: MIN_BLOCKS,
            });
        }
        let mut m = [[0.0f64; INVERT_N]; INVERT_N];
        let mut packed = self.normal.iter();
        for i in 0..INVERT_N {
            for j in i..INVERT_N {
                let v = if j < UNKNOWNS {
                    packed.next().map_or(0.0, |&v| f64::from(v))
                } else {
                    f64::from(u8::from(i == j))
                };
                if let Some(x) = m.get_mut(i).and_then(|r| r.get_mut(j)) {
                    *x = v;
                }
                if let Some(x) = m.get_mut(j).and_then(|r| r.get_mut(i)) {
                    *x = v;
                }
            }
        }
        Ok(m)
    }

    /// The viscous drag and dry friction from the normal matrix's `inverse`.
    fn solved(&self, inverse: &[[f64; INVERT_N]; INVERT_N]) -> Result<GreaseReading, GreaseError> {
        let solve = |i: usize| -> f32 {
            let mut sum = 0.0f64;
            for (a, r) in inverse
                .get(i)
                .map_or(&[0.0; INVERT_N], |r| r)
                .iter()
                .zip(&self.rhs)
            {
                sum += a * f64::from(*r);
            }
            sum as f32
        };
        let (viscous, coulomb) = (solve(2), solve(1));
        if !(viscous.is_finite() && coulomb.is_finite()) {
            return Err(GreaseError::Singular);
        }
        Ok(GreaseReading {
            viscous,
            coulomb,
            blocks: self.blocks,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A motor whose current is exactly the six-term balance: the fit gives back its
    /// viscous and dry terms.
    #[test]
    fn an_exact_torque_balance_is_read_back() {
        let (viscous, coulomb) = (0.02f64, 0.35f64);
        let mut fit = ChirpTorqueFit::ZERO;
        let n = 5000;
        let angle = |k: usize| {
            let t = k as f64 * 1e-4;
            2.5 * (core::f64::consts::TAU * (2.0 + 13.0 * t) * t).sin()
        };
        let user = |k: usize| angle(k) / 500.0 + 1e-4 * (k as f64 * 3e-3).sin();
        for k in 0..n {
            // Speeds and accelerations as the fit sees them: per sample, per block.
            let w = 0.5 * (angle(k + 1) - angle(k.saturating_sub(1)));
            let acc = (0.5 * (angle(k + 2) - angle(k))
                - 0.5 * (angle(k) - angle(k.saturating_sub(2))))
                * 0.5;
            let i = 3.0 * acc * BLOCK as f64
                + coulomb * w.signum()
                + viscous * w * BLOCK as f64
                + 40.0 * user(k)
                + 0.05;
            fit.push(i as f32, angle(k) as f32, user(k) as f32);
        }
        let r = fit.reading().unwrap();
        assert!(r.blocks > 100, "{r:?}");
        assert!((f64::from(r.viscous) / viscous - 1.0).abs() < 0.05, "{r:?}");
        assert!((f64::from(r.coulomb) / coulomb - 1.0).abs() < 0.05, "{r:?}");
    }

    #[test]
    fn the_fit_keeps_156_bytes_of_state() {
        assert_eq!(core::mem::size_of::<ChirpTorqueFit>(), 156);
    }

    #[test]
    fn a_motor_that_does_not_move_gives_no_reading() {
        let mut fit = ChirpTorqueFit::ZERO;
        for _ in 0..5000 {
            fit.push(0.2, 1.0, 0.0);
        }
        assert_eq!(
            fit.reading(),
            Err(GreaseError::TooFewBlocks {
                have: 0,
                need: MIN_BLOCKS
            })
        );
    }
}
