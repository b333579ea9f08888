//! TIM1 (advanced: centre-aligned, repetition counter, dead time, complementary outputs,
//! TRGO), TIM2 (counting TIM1's TRGO in external clock mode 1) and TIM3 (encoder mode, its
//! channel 3 capturing the count on TRC = ITR0) at register level (RM0090 §17–18). Time
//! passes in timer ticks handed in by the board ([`Timer::advance`]); O(events) per call.

/// Register offsets.
pub const CR1: u32 = 0x00;
pub const CR2: u32 = 0x04;
pub const SMCR: u32 = 0x08;
pub const DIER: u32 = 0x0C;
pub const SR: u32 = 0x10;
pub const EGR: u32 = 0x14;
pub const CCMR1: u32 = 0x18;
pub const CCMR2: u32 = 0x1C;
pub const CCER: u32 = 0x20;
pub const CNT: u32 = 0x24;
pub const PSC: u32 = 0x28;
pub const ARR: u32 = 0x2C;
pub const RCR: u32 = 0x30;
pub const CCR1: u32 = 0x34;
pub const BDTR: u32 = 0x44;

/// What an update event or a trigger did, for the timers and converters it drives.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Events {
    /// Update events in the call.
    pub updates: u32,
    /// TRGO pulses in the call (MMS = update: one per update event).
    pub trgo: u32,
}

#[derive(Clone, Debug)]
pub struct Timer {
    words: [u32; 0x50 / 4],
    /// Counter width mask (16 or 32 bits).
    width: u32,
    /// The shadow (active) auto-reload, prescaler and compare values.
    arr: u32,
    psc: u32,
    ccr: [u32; 4],
    /// The repetition down-counter (advanced timers).
    repetition: u32,
    /// Prescaler ticks counted towards the next counter tick.
    prescaled: u32,
    /// Encoder mode: the count the image set, and the encoder's edges then.
    encoder_base: (u32, i64),
    /// Writes to CCR1…CCR4 since reset.
    pub compare_writes: u64,
}

impl Timer {
    pub fn new(width_bits: u32) -> Self {
        let width = if width_bits >= 32 {
            u32::MAX
        } else {
            (1 << width_bits) - 1
        };
        let mut t = Self {
            words: [0; 0x50 / 4],
            width,
            arr: width,
            psc: 0,
            ccr: [0; 4],
            repetition: 0,
            prescaled: 0,
            encoder_base: (0, 0),
            compare_writes: 0,
        };
        t.words[(ARR / 4) as usize] = width;
        t
    }

    fn reg(&self, offset: u32) -> u32 {
        self.words.get(offset as usize / 4).copied().unwrap_or(0)
    }

    fn set(&mut self, offset: u32, value: u32) {
        if let Some(w) = self.words.get_mut(offset as usize / 4) {
            *w = value;
        }
    }

    pub fn read(&self, offset: u32) -> Option<u32> {
        if offset as usize / 4 >= self.words.len() {
            return None;
        }
        Some(match offset {
            EGR => 0,
            _ => self.reg(offset),
        })
    }

    /// A write by the image; `edges` is the encoder's count of edges now (TIM3).
    pub fn write(&mut self, offset: u32, value: u32, edges: i64) -> Option<()> {
        if offset as usize / 4 >= self.words.len() {
            return None;
        }
        match offset {
            // rc_w0: a 0 clears a flag, a 1 leaves it.
            SR => self.set(SR, self.reg(SR) & value),
            EGR => {
                if value & 1 != 0 {
                    self.update_generation();
                }
                // CC3G etc. are not used by the board.
            }
            CNT => {
                self.set(CNT, value & self.width);
                self.encoder_base = (value & self.width, edges);
            }
            CR1 => {
                // DIR is read-only in centre-aligned mode.
                let centre = self.centre_aligned_mode(value);
                let dir = self.reg(CR1) & (1 << 4);
                let v = if centre {
                    (value & !(1 << 4)) | dir
                } else {
                    value
                };
                let starts = self.reg(CR1) & 1 == 0 && v & 1 != 0;
                self.set(CR1, v);
                // RM0090 §17.3.3: in centre-aligned mode an odd RCR written before the
                // counter starts puts every update on an overflow: the first after
                // RCR overflows and underflows, then every RCR + 1.
                let rcr = self.reg(RCR) & 0xff;
                if starts && centre && rcr % 2 == 1 {
                    self.repetition = rcr - 1;
                }
            }
            _ => {
                self.set(offset, value);
                // Without preload the active values follow at once.
                let arpe = self.reg(CR1) & (1 << 7) != 0;
                if offset == ARR && !arpe {
                    self.arr = value & self.width;
                }
                if (CCR1..CCR1 + 16).contains(&offset) {
                    let ch = ((offset - CCR1) / 4) as usize;
                    self.compare_writes += 1;
                    if !self.compare_preload(ch) {
                        self.ccr[ch] = value & self.width;
                    }
                }
            }
        }
        Some(())
    }

    fn centre_aligned_mode(&self, cr1: u32) -> bool {
        (cr1 >> 5) & 3 != 0
    }

    fn compare_preload(&self, ch: usize) -> bool {
        let ccmr = if ch < 2 {
            self.reg(CCMR1)
        } else {
            self.reg(CCMR2)
        };
        ccmr & (1 << (3 + 8 * (ch % 2))) != 0
    }

    /// UG or an update event: the shadow registers take their preloaded values and the
    /// repetition counter its reload (RM0090 §17.3.1–17.3.3).
    fn load_shadows(&mut self) {
        self.arr = self.reg(ARR) & self.width;
        self.psc = self.reg(PSC) & 0xffff;
        for ch in 0..4 {
            self.ccr[ch] = self.reg(CCR1 + 4 * ch as u32) & self.width;
        }
        self.repetition = self.reg(RCR) & 0xff;
    }

    fn update_generation(&mut self) {
        self.load_shadows();
        self.prescaled = 0;
        let down = self.reg(CR1) & (1 << 4) != 0 && !self.centre_aligned_mode(self.reg(CR1));
        self.set(CNT, if down { self.arr } else { 0 });
        // URS = 0: UG sets UIF.
        if self.reg(CR1) & (1 << 2) == 0 {
            self.set(SR, self.reg(SR) | 1);
        }
    }

    /// Counts `ticks` of the timer's kernel clock (before its prescaler) on its internal
    /// clock, if it is enabled and not slaved to another's trigger. O(events).
    pub fn advance(&mut self, ticks: u64) -> Events {
        let mut events = Events::default();
        let cr1 = self.reg(CR1);
        if cr1 & 1 == 0 || self.external_clock() || self.encoder_mode() {
            return events;
        }
        // The prescaler's ticks to counter ticks.
        let divide = u64::from(self.psc) + 1;
        let total = u64::from(self.prescaled) + ticks;
        let mut counts = total / divide;
        self.prescaled = (total % divide) as u32;
        while counts > 0 {
            let cnt = self.reg(CNT);
            let cr1 = self.reg(CR1);
            let centre = self.centre_aligned_mode(cr1);
            let down = cr1 & (1 << 4) != 0;
            let arr = self.arr.max(1);
            let to_event = if !down {
                if centre {
                    u64::from(arr.saturating_sub(cnt))
                } else {
                    u64::from(arr.saturating_sub(cnt)) + 1
                }
            } else {
                u64::from(cnt).max(if centre { 1 } else { 0 }) + u64::from(!centre)
            };
            if counts < to_event {
                let c = counts as u32;
                self.set(CNT, if down { cnt - c } else { cnt + c });
                break;
            }
            counts -= to_event;
            match (centre, down) {
                // Overflow: at the top, turning down.
                (true, false) => {
                    self.set(CNT, arr);
                    self.set(CR1, cr1 | (1 << 4));
                }
                // Underflow: at the bottom, turning up.
                (true, true) => {
                    self.set(CNT, 0);
                    self.set(CR1, cr1 & !(1 << 4));
                }
                (false, false) => self.set(CNT, 0),
                (false, true) => self.set(CNT, arr),
            }
            self.overflow_or_underflow(&mut events);
        }
        events
    }

    fn overflow_or_underflow(&mut self, events: &mut Events) {
        if self.repetition > 0 {
            self.repetition -= 1;
            return;
        }
        self.load_shadows();
        self.set(SR, self.reg(SR) | 1);
        events.updates += 1;
        // MMS = 010: TRGO on update.
        if (self.reg(CR2) >> 4) & 7 == 0b010 {
            events.trgo += 1;
        }
    }

    /// Slave mode: external clock mode 1 (SMS = 111).
    fn external_clock(&self) -> bool {
        self.reg(SMCR) & 7 == 7
    }

    /// Encoder modes 1–3 (SMS = 001 … 011).
    pub fn encoder_mode(&self) -> bool {
        (1..=3).contains(&(self.reg(SMCR) & 7))
    }

    /// The trigger input's source (TS): 0 is ITR0.
    pub fn trigger_source(&self) -> u32 {
        (self.reg(SMCR) >> 4) & 7
    }

    /// A rising edge on ITR0 (TIM1's TRGO for TIM2 and TIM3): counted in external clock
    /// mode 1; captured on every channel whose input is TRC (CCxS = 11) and enabled.
    pub fn trigger(&mut self, pulses: u32) {
        if pulses == 0 || self.trigger_source() != 0 {
            return;
        }
        if self.external_clock() && self.reg(CR1) & 1 != 0 {
            for _ in 0..pulses {
                let cnt = self.reg(CNT);
                if cnt >= self.arr {
                    self.set(CNT, 0);
                    self.set(SR, self.reg(SR) | 1);
                } else {
                    self.set(CNT, cnt + 1);
                }
            }
        }
        for ch in 0..4u32 {
            let ccmr = if ch < 2 {
                self.reg(CCMR1)
            } else {
                self.reg(CCMR2)
            };
            let ccs = (ccmr >> (8 * (ch % 2))) & 3;
            if ccs == 3 && self.reg(CCER) & (1 << (4 * ch)) != 0 {
                self.set(CCR1 + 4 * ch, self.reg(CNT));
                self.ccr[ch as usize] = self.reg(CNT);
                let sr = self.reg(SR);
                // A capture over an unread one sets the overcapture flag.
                let over = if sr & (1 << (1 + ch)) != 0 {
                    1 << (9 + ch)
                } else {
                    0
                };
                self.set(SR, sr | (1 << (1 + ch)) | over);
            }
        }
    }

    /// Encoder mode: the counter follows the encoder's edges (×4 in mode 3, the board's).
    pub fn follow_encoder(&mut self, edges: i64) {
        if !self.encoder_mode() || self.reg(CR1) & 1 == 0 {
            return;
        }
        let (base, at) = self.encoder_base;
        let modulus = i64::from(self.arr) + 1;
        let count = (i64::from(base) + (edges - at)).rem_euclid(modulus);
        self.set(CNT, count as u32);
    }

    /// The active compare value of channel `ch` (0-based) and whether its outputs are on.
    pub fn compare(&self, ch: usize) -> (u32, bool, bool) {
        let ccer = self.reg(CCER);
        (
            self.ccr.get(ch).copied().unwrap_or(0),
            ccer & (1 << (4 * ch)) != 0,
            ccer & (1 << (4 * ch + 2)) != 0,
        )
    }

    pub fn active_arr(&self) -> u32 {
        self.arr
    }

    pub fn main_output_enabled(&self) -> bool {
        self.reg(BDTR) & (1 << 15) != 0
    }

    /// The dead time [timer ticks] from BDTR's DTG and CR1's CKD (RM0090 §17.4.18).
    pub fn dead_time_ticks(&self) -> u32 {
        let dtg = self.reg(BDTR) & 0xff;
        let ckd = 1u32 << ((self.reg(CR1) >> 8) & 3).min(2);
        let t = if dtg & 0x80 == 0 {
            dtg
        } else if dtg & 0xC0 == 0x80 {
            (64 + (dtg & 0x3f)) * 2
        } else if dtg & 0xE0 == 0xC0 {
            (32 + (dtg & 0x1f)) * 8
        } else {
            (32 + (dtg & 0x1f)) * 16
        };
        t * ckd
    }

    /// Whether the image asked for an interrupt (DIER) this model does not deliver.
    pub fn interrupts_enabled(&self) -> u32 {
        self.reg(DIER) & 0xff
    }

    pub fn raw(&self, offset: u32) -> u32 {
        self.reg(offset)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bridge timer as `board.rs` starts it: centre-aligned, ARR, RCR, UG, UIF cleared.
    fn bridge(arr: u32, rcr: u32) -> Timer {
        let mut t = Timer::new(16);
        t.write(CR1, (0b01 << 5) | (1 << 7), 0).unwrap();
        t.write(ARR, arr, 0).unwrap();
        t.write(RCR, rcr, 0).unwrap();
        t.write(CR2, 0b010 << 4, 0).unwrap();
        t.write(EGR, 1, 0).unwrap();
        t.write(SR, !1, 0).unwrap();
        t.write(CR1, (0b01 << 5) | (1 << 7) | 1, 0).unwrap();
        t
    }

    #[test]
    fn an_odd_repetition_written_before_the_start_updates_at_the_top() {
        // RCR = 3 (two carriers): the first update on the second overflow, then every
        // fourth overflow or underflow, always at the top.
        let mut t = bridge(100, 3);
        assert_eq!(t.advance(299).updates, 0);
        let e = t.advance(1);
        assert_eq!((e.updates, e.trgo), (1, 1));
        assert_ne!(
            t.read(CR1).unwrap() & (1 << 4),
            0,
            "counting down after the top"
        );
        assert_eq!(t.advance(399).updates, 0);
        assert_eq!(t.advance(1).updates, 1);
        assert_ne!(t.read(CR1).unwrap() & (1 << 4), 0, "again at the top");
    }

    #[test]
    fn an_even_repetition_alternates_between_top_and_bottom() {
        // RCR = 2: every third overflow or underflow.
        let mut t = bridge(100, 2);
        assert_eq!(t.advance(300).updates, 1);
        let top = t.read(CR1).unwrap() & (1 << 4);
        assert_eq!(t.advance(300).updates, 1);
        assert_ne!(t.read(CR1).unwrap() & (1 << 4), top);
    }

    #[test]
    fn the_dead_time_generator_decodes_its_four_ranges() {
        let mut t = Timer::new(16);
        for (dtg, ticks) in [(0x40, 64), (0x85, 138), (0xC3, 280), (0xE1, 528)] {
            t.write(BDTR, dtg, 0).unwrap();
            assert_eq!(t.dead_time_ticks(), ticks, "DTG {dtg:#x}");
        }
    }

    #[test]
    fn a_slave_counts_triggers_and_captures_on_trc() {
        let mut t2 = Timer::new(32);
        t2.write(SMCR, 7, 0).unwrap();
        t2.write(CR1, 1, 0).unwrap();
        t2.trigger(3);
        assert_eq!(t2.read(CNT), Some(3));
        let mut t3 = Timer::new(16);
        t3.write(SMCR, 3, 0).unwrap();
        t3.write(CCMR2, 3, 0).unwrap();
        t3.write(CCER, 1 << 8, 0).unwrap();
        t3.write(CR1, 1, 0).unwrap();
        t3.follow_encoder(-5);
        t3.trigger(1);
        assert_eq!(t3.read(CCR1 + 8), Some(65531));
    }
}
