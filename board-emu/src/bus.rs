//! The STM32F405's peripheral space as the board image sees it: each access dispatched to
//! its register model by address; an access to a register no model holds is recorded as a
//! fault (the run reports it and stops) rather than answered. Work per access: O(1).

use crate::adc::Adc;
use crate::clocks::Rcc;
use crate::flash::FlashInterface;
use crate::timers::Timer;

pub const TIM2: u32 = 0x4000_0000;
pub const TIM3: u32 = 0x4000_0400;
pub const PWR: u32 = 0x4000_7000;
pub const TIM1: u32 = 0x4001_0000;
pub const ADC1: u32 = 0x4001_2000;
pub const ADC2: u32 = 0x4001_2100;
pub const ADC_COMMON: u32 = 0x4001_2300;
pub const SYSCFG: u32 = 0x4001_3800;
pub const GPIOA: u32 = 0x4002_0000;
pub const RCC: u32 = 0x4002_3800;
pub const FLASH_INTERFACE: u32 = 0x4002_3C00;
pub const SCS: u32 = 0xE000_E000;
pub const DWT: u32 = 0xE000_1000;
pub const DBGMCU: u32 = 0xE004_2000;

/// GPIO ports A … I.
pub const GPIO_PORTS: usize = 9;

/// A plain register block: what is written reads back.
#[derive(Clone, Debug)]
pub struct Registers {
    words: Vec<u32>,
}

impl Registers {
    pub fn new(bytes: usize) -> Self {
        Self {
            words: vec![0; bytes / 4],
        }
    }

    pub fn read(&self, offset: u32) -> Option<u32> {
        self.words.get(offset as usize / 4).copied()
    }

    pub fn write(&mut self, offset: u32, value: u32) -> Option<()> {
        *self.words.get_mut(offset as usize / 4)? = value;
        Some(())
    }

    /// A byte or halfword write merged into its word.
    pub fn write_sized(&mut self, offset: u32, size: usize, value: u32) -> Option<()> {
        let word = self.read(offset & !3)?;
        self.write(offset & !3, merged(word, offset, size, value))
    }
}

/// `word` with the byte or halfword `value` of a `size`-byte write at `address` in it.
fn merged(word: u32, address: u32, size: usize, value: u32) -> u32 {
    let shift = 8 * (address & 3);
    let mask = match size {
        1 => 0xffu32,
        2 => 0xffff,
        _ => u32::MAX,
    } << shift;
    (word & !mask) | ((value << shift) & mask)
}

/// An access no model answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unmodelled {
    pub address: u32,
    pub write: bool,
}

/// Every modelled peripheral.
#[derive(Clone)]
pub struct Bus {
    pub rcc: Rcc,
    pub flash: FlashInterface,
    pub tim1: Timer,
    pub tim2: Timer,
    pub tim3: Timer,
    pub adc1: Adc,
    pub adc2: Adc,
    pub adc_common: Registers,
    pub gpio: Vec<Registers>,
    pub pwr: Registers,
    pub syscfg: Registers,
    pub scs: Registers,
    pub dwt: Registers,
    pub dbgmcu: Registers,
    pub unmodelled: Vec<Unmodelled>,
    /// The encoder's quadrature edges now (the plant's).
    pub encoder_edges: i64,
    /// Cycles since reset (one per instruction), for DWT's cycle counter.
    pub cycles: u64,
}

/// GPIO register block: MODER … AFRH (0x00 … 0x24).
const GPIO_BYTES: usize = 0x28;

impl Bus {
    pub fn new(flash: FlashInterface) -> Self {
        let mut gpio: Vec<Registers> = (0..GPIO_PORTS)
            .map(|_| Registers::new(GPIO_BYTES))
            .collect();
        // Reset: PA13/PA14/PA15 and PB3/PB4 in their debug functions (RM0090 §8.4.1).
        let _ = gpio[0].write(0x00, 0xA800_0000);
        let _ = gpio[1].write(0x00, 0x0000_0280);
        let mut scs = Registers::new(0x1000);
        // CPUID: Cortex-M4 r0p1.
        let _ = scs.write(0xD00, 0x410F_C241);
        let mut dbgmcu = Registers::new(0x10);
        // IDCODE: STM32F405/407, revision Z.
        let _ = dbgmcu.write(0x00, 0x1001_6413);
        Self {
            rcc: Rcc::reset(),
            flash,
            tim1: Timer::new(16),
            tim2: Timer::new(32),
            tim3: Timer::new(16),
            adc1: Adc::default(),
            adc2: Adc::default(),
            adc_common: Registers::new(0x10),
            gpio,
            pwr: Registers::new(0x8),
            syscfg: Registers::new(0x30),
            scs,
            dwt: Registers::new(0x1000),
            dbgmcu,
            unmodelled: Vec::new(),
            encoder_edges: 0,
            cycles: 0,
        }
    }

    pub fn read(&mut self, address: u32, size: usize) -> u32 {
        let word = self.read_word(address & !3);
        let value = word.map(|w| w >> (8 * (address & 3)));
        match value {
            Some(v) => match size {
                1 => v & 0xff,
                2 => v & 0xffff,
                _ => v,
            },
            None => {
                self.unmodelled.push(Unmodelled {
                    address,
                    write: false,
                });
                0
            }
        }
    }

    fn read_word(&mut self, a: u32) -> Option<u32> {
        match a {
            TIM2..=0x4000_03FF => self.tim2.read(a - TIM2),
            TIM3..=0x4000_07FF => {
                self.tim3.follow_encoder(self.encoder_edges);
                self.tim3.read(a - TIM3)
            }
            PWR..=0x4000_73FF => self.pwr.read(a - PWR),
            TIM1..=0x4001_03FF => self.tim1.read(a - TIM1),
            ADC1..=0x4001_20FF => self.adc1.read(a - ADC1),
            ADC2..=0x4001_21FF => self.adc2.read(a - ADC2),
            ADC_COMMON..=0x4001_23FF => self.adc_common.read(a - ADC_COMMON),
            SYSCFG..=0x4001_3BFF => self.syscfg.read(a - SYSCFG),
            GPIOA..=0x4002_23FF => {
                let port = ((a - GPIOA) / 0x400) as usize;
                self.gpio.get(port)?.read((a - GPIOA) % 0x400)
            }
            RCC..=0x4002_3BFF => self.rcc.read(a - RCC),
            FLASH_INTERFACE..=0x4002_3FFF => self.flash.read_register(a - FLASH_INTERFACE),
            DWT..=0xE000_1FFF => {
                if a - DWT == 4 {
                    Some(self.cycles as u32)
                } else {
                    self.dwt.read(a - DWT)
                }
            }
            SCS..=0xE000_EFFF => self.scs.read(a - SCS),
            DBGMCU..=0xE004_200F => self.dbgmcu.read(a - DBGMCU),
            _ => None,
        }
    }

    pub fn write(&mut self, address: u32, size: usize, value: u32) {
        let a = address & !3;
        // Byte and halfword writes merge into the word (NVIC's priority bytes, GPIO's BSRR
        // halves); the timers and converters are written a word at a time.
        let edges = self.encoder_edges;
        let done = match a {
            TIM2..=0x4000_03FF => self.tim2.write(a - TIM2, value, edges),
            TIM3..=0x4000_07FF => {
                self.tim3.follow_encoder(edges);
                self.tim3.write(a - TIM3, value, edges)
            }
            PWR..=0x4000_73FF => self.pwr.write_sized(address - PWR, size, value),
            TIM1..=0x4001_03FF => self.tim1.write(a - TIM1, value, edges),
            ADC1..=0x4001_20FF => self.adc1.write(a - ADC1, value),
            ADC2..=0x4001_21FF => self.adc2.write(a - ADC2, value),
            ADC_COMMON..=0x4001_23FF => self.adc_common.write(a - ADC_COMMON, value),
            SYSCFG..=0x4001_3BFF => self.syscfg.write(a - SYSCFG, value),
            GPIOA..=0x4002_23FF => {
                let port = ((a - GPIOA) / 0x400) as usize;
                let offset = (a - GPIOA) % 0x400;
                match self.gpio.get_mut(port) {
                    // BSRR: set and reset ODR's bits.
                    Some(g) if offset == 0x18 => {
                        let v = merged(0, address, size, value);
                        let odr = g.read(0x14).unwrap_or(0);
                        g.write(0x14, (odr | (v & 0xffff)) & !(v >> 16))
                    }
                    Some(g) => g.write_sized(address - GPIOA - 0x400 * port as u32, size, value),
                    None => None,
                }
            }
            RCC..=0x4002_3BFF => {
                let current = self.rcc.read(a - RCC).unwrap_or(0);
                self.rcc
                    .write(a - RCC, merged(current, address, size, value))
            }
            FLASH_INTERFACE..=0x4002_3FFF => self.flash.write_register(a - FLASH_INTERFACE, value),
            DWT..=0xE000_1FFF => self.dwt.write_sized(address - DWT, size, value),
            SCS..=0xE000_EFFF => self.scs.write_sized(address - SCS, size, value),
            DBGMCU..=0xE004_200F => self.dbgmcu.write_sized(address - DBGMCU, size, value),
            _ => None,
        };
        if done.is_none() {
            self.unmodelled.push(Unmodelled {
                address,
                write: true,
            });
        }
    }

    /// A GPIO pin's mode (MODER: 0 input, 1 output, 2 alternate, 3 analog) and alternate
    /// function; `port` 0 = A.
    pub fn pin(&self, port: usize, pin: u32) -> (u32, u32) {
        let g = &self.gpio[port];
        let mode = (g.read(0x00).unwrap_or(0) >> (2 * pin)) & 3;
        let afr = if pin < 8 {
            g.read(0x20).unwrap_or(0) >> (4 * pin)
        } else {
            g.read(0x24).unwrap_or(0) >> (4 * (pin - 8))
        } & 0xf;
        (mode, afr)
    }
}
