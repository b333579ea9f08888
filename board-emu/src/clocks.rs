//! RCC and the flash interface's access control (RM0090 §7, §3.9): the registers the image
//! writes, the ready bits that follow what it enabled (HSE, PLL, LSI, LSE, the system clock
//! switch), and the clock tree those registers configure, checked against what `board.rs`
//! claims. Work per access: O(1).

/// The board's crystal [Hz].
pub const HSE_HZ: u32 = 8_000_000;
const HSI_HZ: u32 = 16_000_000;

/// RCC's registers (offsets from 0x4002_3800) as the image left them.
#[derive(Clone, Debug)]
pub struct Rcc {
    words: [u32; 0x90 / 4],
}

const CR: usize = 0x00;
const PLLCFGR: usize = 0x04;
const CFGR: usize = 0x08;
const BDCR: usize = 0x70;
const CSR: usize = 0x74;

impl Rcc {
    /// The reset values RM0090 §7.3 gives (PLLCFGR 0x2400_3010, CR with HSI on and ready).
    pub fn reset() -> Self {
        let mut r = Self {
            words: [0; 0x90 / 4],
        };
        r.words[CR / 4] = 0x0000_0083;
        r.words[PLLCFGR / 4] = 0x2400_3010;
        r
    }

    pub fn read(&self, offset: u32) -> Option<u32> {
        let v = *self.words.get(offset as usize / 4)?;
        Some(match offset as usize {
            // HSIRDY, HSERDY, PLLRDY, PLLI2SRDY follow their ON bits.
            CR => {
                let mut v = v & !((1 << 1) | (1 << 17) | (1 << 25) | (1 << 27));
                for on in [0, 16, 24, 26] {
                    if v & (1 << on) != 0 {
                        v |= 1 << (on + 1);
                    }
                }
                v
            }
            // SWS follows SW (a switch to the PLL or HSE only once it is ready).
            CFGR => {
                let sw = v & 3;
                let cr = self.read(CR as u32).unwrap_or(0);
                let ready = match sw {
                    0 => cr & (1 << 1) != 0,
                    1 => cr & (1 << 17) != 0,
                    2 => cr & (1 << 25) != 0,
                    _ => false,
                };
                let sws = if ready { sw } else { 0 };
                (v & !0xC) | (sws << 2)
            }
            // LSERDY follows LSEON; LSIRDY follows LSION.
            BDCR | CSR => (v & !2) | ((v & 1) << 1),
            _ => v,
        })
    }

    pub fn write(&mut self, offset: u32, value: u32) -> Option<()> {
        *self.words.get_mut(offset as usize / 4)? = value;
        Some(())
    }

    /// Whether the peripheral clock enable `bit` of the enable register at `offset` is set
    /// (AHB1ENR 0x30, APB1ENR 0x40, APB2ENR 0x44).
    pub fn enabled(&self, offset: u32, bit: u32) -> bool {
        self.words
            .get(offset as usize / 4)
            .is_some_and(|w| w & (1 << bit) != 0)
    }

    /// The clock tree the registers configure.
    pub fn tree(&self) -> Result<ClockTree, ClockError> {
        let cfgr = self.read(CFGR as u32).unwrap_or(0);
        let pll = self.words[PLLCFGR / 4];
        let source = match cfgr & 3 {
            0 => HSI_HZ as u64,
            1 => HSE_HZ as u64,
            2 => {
                let m = u64::from(pll & 0x3f);
                let n = u64::from((pll >> 6) & 0x1ff);
                let p = 2 * (u64::from((pll >> 16) & 3) + 1);
                let input = if pll & (1 << 22) != 0 { HSE_HZ } else { HSI_HZ } as u64;
                if m < 2 || !(50..=432).contains(&n) {
                    return Err(ClockError::PllOutOfRange { m, n });
                }
                let vco_in = input / m;
                let vco = vco_in * n;
                if !(1_000_000..=2_000_000).contains(&vco_in)
                    || !(100_000_000..=432_000_000).contains(&vco)
                {
                    return Err(ClockError::PllOutOfRange { m, n });
                }
                vco / p
            }
            _ => return Err(ClockError::NoSystemClock),
        };
        let hpre = (cfgr >> 4) & 0xf;
        let ahb_div = if hpre < 8 {
            1
        } else {
            1u64 << (hpre - 7 + u32::from(hpre >= 12))
        };
        let apb_div = |bits: u32| if bits < 4 { 1u64 } else { 1 << (bits - 3) };
        let hclk = source / ahb_div;
        let (d1, d2) = (apb_div((cfgr >> 10) & 7), apb_div((cfgr >> 13) & 7));
        let (apb1, apb2) = (hclk / d1, hclk / d2);
        Ok(ClockTree {
            sysclk: source as u32,
            hclk: hclk as u32,
            apb1: apb1 as u32,
            apb2: apb2 as u32,
            // A timer on an APB with a prescaler other than 1 runs at twice its bus.
            apb1_timers: (if d1 == 1 { apb1 } else { 2 * apb1 }) as u32,
            apb2_timers: (if d2 == 1 { apb2 } else { 2 * apb2 }) as u32,
        })
    }
}

/// Frequencies [Hz] the RCC's registers configure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClockTree {
    pub sysclk: u32,
    pub hclk: u32,
    pub apb1: u32,
    pub apb2: u32,
    pub apb1_timers: u32,
    pub apb2_timers: u32,
}

impl ClockTree {
    /// What `board.rs` claims: 168 MHz from the 8 MHz crystal, APB1 42 MHz (timers 84),
    /// APB2 84 MHz (timers 168).
    pub const BOARD: Self = Self {
        sysclk: 168_000_000,
        hclk: 168_000_000,
        apb1: 42_000_000,
        apb2: 84_000_000,
        apb1_timers: 84_000_000,
        apb2_timers: 168_000_000,
    };
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockError {
    PllOutOfRange { m: u64, n: u64 },
    NoSystemClock,
}

/// Wait states the flash needs at `hclk` on a 2.7–3.6 V supply (RM0090 Table 10: one per
/// 30 MHz).
pub fn wait_states_needed(hclk: u32) -> u32 {
    hclk.saturating_sub(1) / 30_000_000
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The registers embassy-stm32 writes for `board.rs`'s `clocks()`: HSE on, PLL from
    /// HSE with M = 4, N = 168, P = 2, Q = 7, AHB /1, APB1 /4, APB2 /2, SW = PLL.
    fn board_rcc() -> Rcc {
        let mut r = Rcc::reset();
        r.write(0x00, (1 << 16) | (1 << 24)).unwrap();
        r.write(0x04, 4 | (168 << 6) | (1 << 22) | (7 << 24))
            .unwrap();
        r.write(0x08, 2 | (0b101 << 10) | (0b100 << 13)).unwrap();
        r
    }

    #[test]
    fn the_boards_registers_give_the_boards_clocks() {
        assert_eq!(board_rcc().tree(), Ok(ClockTree::BOARD));
        assert_eq!(wait_states_needed(168_000_000), 5);
    }

    #[test]
    fn a_wrong_prescaler_or_multiplier_gives_other_clocks() {
        let mut r = board_rcc();
        // APB2 /4 instead of /2: the bridge timer at 84 MHz.
        r.write(0x08, 2 | (0b101 << 10) | (0b101 << 13)).unwrap();
        let t = r.tree().unwrap();
        assert_eq!((t.apb2, t.apb2_timers), (42_000_000, 84_000_000));
        let mut r = board_rcc();
        r.write(0x04, 4 | (160 << 6) | (1 << 22) | (7 << 24))
            .unwrap();
        assert_eq!(r.tree().unwrap().sysclk, 160_000_000);
    }

    #[test]
    fn the_system_clock_switches_only_to_a_ready_source() {
        let mut r = Rcc::reset();
        r.write(0x08, 2).unwrap();
        // PLL not on: SWS stays on the HSI.
        assert_eq!(r.read(0x08).unwrap() & 0xC, 0);
        r.write(0x00, 1 << 24).unwrap();
        assert_eq!(r.read(0x08).unwrap() & 0xC, 0b1000);
    }
}
