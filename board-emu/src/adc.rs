//! ADC1 and ADC2's injected group (RM0090 §13): ranks from JSQR, sample times from SMPR,
//! started by TIM1's TRGO when JEXTSEL/JEXTEN say so, converting what the plant puts on the
//! pins, JEOC once every rank is done. Work per trigger: O(ranks).

pub const SR: u32 = 0x00;
pub const CR1: u32 = 0x04;
pub const CR2: u32 = 0x08;
pub const SMPR1: u32 = 0x0C;
pub const SMPR2: u32 = 0x10;
pub const JSQR: u32 = 0x38;
pub const JDR1: u32 = 0x3C;

/// JEXTSEL of TIM1's TRGO.
pub const TIM1_TRGO: u32 = 0b0001;

/// ADC cycles per sample time code SMP = 0 … 7.
const SAMPLE_CYCLES: [u32; 8] = [3, 15, 28, 56, 84, 112, 144, 480];

#[derive(Clone, Debug, Default)]
pub struct Adc {
    words: [u32; 0x50 / 4],
    /// A conversion in progress: the results and the ADC clock cycles left.
    pending: Option<([u16; 4], u64)>,
}

impl Adc {
    fn reg(&self, offset: u32) -> u32 {
        self.words.get(offset as usize / 4).copied().unwrap_or(0)
    }

    pub fn read(&self, offset: u32) -> Option<u32> {
        self.words.get(offset as usize / 4).copied()
    }

    pub fn write(&mut self, offset: u32, value: u32) -> Option<()> {
        let w = self.words.get_mut(offset as usize / 4)?;
        *w = match offset {
            // rc_w0 flags.
            SR => *w & value,
            _ => value,
        };
        Some(())
    }

    /// The injected group's channels in conversion order (RM0090 §13.13.12: with JL + 1 = n
    /// ranks the sequence is JSQ(4 − n + 1) … JSQ4).
    pub fn injected_channels(&self) -> Vec<u8> {
        let jsqr = self.reg(JSQR);
        let n = ((jsqr >> 20) & 3) as usize + 1;
        (4 - n..4)
            .map(|rank| ((jsqr >> (5 * rank)) & 0x1f) as u8)
            .collect()
    }

    /// Sample time [ADC cycles] of `channel`.
    pub fn sample_cycles(&self, channel: u8) -> u32 {
        let c = u32::from(channel);
        let smp = if c < 10 {
            (self.reg(SMPR2) >> (3 * c)) & 7
        } else {
            (self.reg(SMPR1) >> (3 * (c - 10))) & 7
        };
        SAMPLE_CYCLES[smp as usize]
    }

    /// Whether TIM1's TRGO starts the injected group (ADON, JEXTEN rising, JEXTSEL).
    pub fn triggered_by_tim1_trgo(&self) -> bool {
        let cr2 = self.reg(CR2);
        cr2 & 1 != 0 && (cr2 >> 20) & 3 == 0b01 && (cr2 >> 16) & 0xf == TIM1_TRGO
    }

    /// A trigger: every rank sampled now from `volts(channel)` (the pin's voltage on a
    /// 3.3 V reference, 12 bits), the results ready after the ranks' conversion time.
    pub fn start_injected(&mut self, volts: impl Fn(u8) -> f32) {
        if !self.triggered_by_tim1_trgo() {
            return;
        }
        let channels = self.injected_channels();
        let mut results = [0u16; 4];
        let mut cycles = 0u64;
        for (slot, &ch) in results.iter_mut().zip(&channels) {
            let v = volts(ch).clamp(0.0, 3.3);
            *slot = (v / 3.3 * 4096.0).floor().min(4095.0) as u16;
            cycles += u64::from(self.sample_cycles(ch) + 12);
        }
        // JSTRT at once.
        self.words[(SR / 4) as usize] |= 1 << 3;
        self.pending = Some((results, cycles));
    }

    /// `cycles` ADC clock cycles pass: a conversion that ends writes JDRx and sets JEOC.
    pub fn advance(&mut self, cycles: u64) {
        if let Some((results, left)) = self.pending {
            if cycles >= left {
                for (i, r) in results.iter().enumerate() {
                    self.words[(JDR1 / 4) as usize + i] = u32::from(*r);
                }
                self.words[(SR / 4) as usize] |= 1 << 2;
                self.pending = None;
            } else {
                self.pending = Some((results, left - cycles));
            }
        }
    }

    /// The conversion in progress: its results, in rank order.
    pub fn pending_results(&self) -> Option<[u16; 4]> {
        self.pending.map(|(r, _)| r)
    }

    /// Whether the last conversion has finished (its results in JDR).
    pub fn pending_done(&self) -> bool {
        self.pending.is_none()
    }

    /// The interrupt enables (JEOCIE, EOCIE, AWDIE, OVRIE) this model does not deliver.
    pub fn interrupts_enabled(&self) -> u32 {
        self.reg(CR1) & ((1 << 5) | (1 << 6) | (1 << 7) | (1 << 26))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_ranks_convert_in_order_on_the_trigger() {
        let mut adc = Adc::default();
        adc.write(CR2, 1 | (0b01 << 20) | (TIM1_TRGO << 16))
            .unwrap();
        adc.write(JSQR, (3 << 20) | 1 << 5 | 2 << 10 | 3 << 15)
            .unwrap();
        adc.write(SMPR2, 0o1111).unwrap();
        adc.start_injected(|ch| f32::from(ch) * 0.5);
        assert_eq!(adc.read(SR).unwrap() & 4, 0);
        adc.advance(4 * 27);
        assert_ne!(adc.read(SR).unwrap() & 4, 0);
        let jdr: Vec<u32> = (0..4).map(|i| adc.read(JDR1 + 4 * i).unwrap()).collect();
        assert_eq!(jdr, [0, 620, 1241, 1861]);
    }

    #[test]
    fn two_ranks_sit_at_the_top_of_jsqr() {
        let mut adc = Adc::default();
        adc.write(JSQR, (1 << 20) | (10 << 10) | (11 << 15))
            .unwrap();
        assert_eq!(adc.injected_channels(), [10, 11]);
    }

    #[test]
    fn another_trigger_source_converts_nothing() {
        let mut adc = Adc::default();
        adc.write(CR2, 1 | (0b01 << 20) | (0b0011 << 16)).unwrap();
        adc.start_injected(|_| 1.0);
        adc.advance(1000);
        assert_eq!(adc.read(SR).unwrap() & 4, 0);
    }
}
