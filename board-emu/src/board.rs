//! The board: the image's segments in flash and RAM, the core (unicorn-engine, Cortex-M4,
//! Thumb, M-class), the peripheral space through [`Bus`], the data sectors through the
//! flash interface, and the plant on the pins. Time: one core cycle per instruction at the
//! configured SYSCLK (QEMU `-icount`'s convention), the peripherals advanced after every
//! [`CHUNK`] instructions (≈ 1.5 µs at 168 MHz: the resolution of every event the image
//! sees). No interrupt is delivered: the board image polls, and a model whose interrupt the
//! image enables ends the run.

use std::cell::RefCell;
use std::rc::Rc;

use anyhow::{anyhow, Result};
use unicorn_engine::unicorn_const::{Arch, Mode, Prot};
use unicorn_engine::{RegisterARM, Unicorn};

use crate::bus::{Bus, Unmodelled};
use crate::clocks::ClockTree;
use crate::elf::Image;
use crate::flash::{FlashInterface, DATA_START, FLASH_END};
use crate::plant::{BridgeState, Plant};

/// ADC common control register's offset (ADCPRE in bits 16–17).
const ADC_CCR: u32 = 0x04;

/// Instructions between two updates of the peripherals.
pub const CHUNK: usize = 256;

const FLASH_BASE: u64 = 0x0800_0000;
const SRAM: (u64, u64) = (0x2000_0000, 128 << 10);
const CCM: (u64, u64) = (0x1000_0000, 64 << 10);
/// QEMU's exception numbers for WFI and WFE.
const EXCP_HLT: u32 = 0x10001;
const EXCP_YIELD: u32 = 0x10004;
/// `wfe` and `wfi` in Thumb.
const WFE: u16 = 0xbf20;
const WFI: u16 = 0xbf30;

/// Why a run ended.
#[derive(Clone, Debug, PartialEq)]
pub enum RunEnd {
    /// The core sleeps (`wfi`) with nothing modelled to wake it: the image is done.
    Asleep { pc: u32 },
    /// The instruction budget ran out.
    InstructionLimit,
    /// The image touched a register no model holds.
    Unmodelled(Unmodelled),
    /// The core faulted (unmapped memory, an undefined instruction).
    CoreFault { pc: u32, error: String },
    /// The image enabled an interrupt the models do not deliver.
    InterruptEnabled(&'static str),
}

/// Triggers and frame reads: how long after each trigger the image took its frame.
#[derive(Clone, Debug, Default)]
pub struct FrameTiming {
    /// Instruction count at the last trigger not yet read.
    pub pending_trigger: Option<u64>,
    pub triggers: u64,
    /// Instructions from a trigger to the chunk in which the image read ADC1's JDR1.
    pub latencies: Vec<u64>,
    /// Instructions from a trigger to the chunk in which the image had written the three
    /// legs' compare registers (the duties for the next update: its deadline), and TIM1's
    /// compare writes at the trigger.
    pub to_duties: Vec<u64>,
    pub pending_duties: Option<(u64, u64)>,
    /// Each frame's conversions and encoder capture, as the image read them (the triggers
    /// whose frame it took, in order; a re-run's frames after the first test's).
    pub fed: Vec<firmware::acquisition::Counts>,
    /// The last trigger's conversions and capture, until the image reads them.
    pub pending_counts: Option<firmware::acquisition::Counts>,
}

/// A board's state to come back to ([`Board::snapshot`]).
pub struct Snapshot {
    context: unicorn_engine::Context,
    ram: Vec<Vec<u8>>,
    pub bus: Bus,
    counts: (u64, u64, u64, u64),
    frames: FrameTiming,
    log: usize,
}

pub struct Board<'a> {
    uc: Unicorn<'a, ()>,
    pub bus: Rc<RefCell<Bus>>,
    rtt: Option<u32>,
    /// QEMU exception numbers the core raised (not WFE's).
    exceptions: Rc<RefCell<Vec<u32>>>,
    /// defmt bytes from RTT channel 0.
    pub log: Vec<u8>,
    pub instructions: u64,
    plant: Box<dyn Plant>,
    /// Timer and converter ticks already counted, as fractions of the core's cycles.
    timer_ticks: u64,
    apb1_ticks: u64,
    adc_ticks: u64,
    pub frames: FrameTiming,
    /// The clock tree the image configured, read when TIM1 first starts.
    pub clocks: Option<ClockTree>,
    pub latency_at_start: u32,
}

fn uc_err(e: unicorn_engine::unicorn_const::uc_error) -> anyhow::Error {
    anyhow!("unicorn: {e:?}")
}

impl<'a> Board<'a> {
    /// The board with `elf` programmed, the data sectors as `flash` holds them, and `plant`
    /// on its pins, out of reset.
    pub fn new(elf: &[u8], flash: FlashInterface, plant: Box<dyn Plant>) -> Result<Self> {
        let image = Image::parse(elf)?;
        let mut uc = Unicorn::new(Arch::ARM, Mode::THUMB | Mode::MCLASS).map_err(uc_err)?;
        uc.ctl_set_cpu_model(unicorn_engine::ArmCpuModel::CORTEX_M4 as i32)
            .map_err(uc_err)?;
        // Sectors 0–4 hold the code; 5–11 are data behind the flash interface.
        uc.mem_map(
            FLASH_BASE,
            u64::from(DATA_START) - FLASH_BASE,
            Prot::READ | Prot::EXEC,
        )
        .map_err(uc_err)?;
        uc.mem_map(SRAM.0, SRAM.1, Prot::ALL).map_err(uc_err)?;
        uc.mem_map(CCM.0, CCM.1, Prot::READ | Prot::WRITE)
            .map_err(uc_err)?;
        for s in &image.segments {
            let end = u64::from(s.address) + s.bytes.len() as u64;
            let in_code = u64::from(s.address) >= FLASH_BASE && end <= u64::from(DATA_START);
            let in_ram = [SRAM, CCM]
                .iter()
                .any(|&(b, n)| u64::from(s.address) >= b && end <= b + n);
            if !(in_code || in_ram) {
                return Err(anyhow!(
                    "a segment at {:#x} ({} bytes) lies outside sectors 0–4 and RAM",
                    s.address,
                    s.bytes.len()
                ));
            }
            uc.mem_write(u64::from(s.address), &s.bytes)
                .map_err(uc_err)?;
        }
        let bus = Rc::new(RefCell::new(Bus::new(flash)));
        // The data sectors: reads and programming through the flash interface.
        let (r, w) = (bus.clone(), bus.clone());
        uc.mmio_map(
            u64::from(DATA_START),
            u64::from(FLASH_END - DATA_START),
            Some(move |_: &mut Unicorn<()>, off: u64, size: usize| {
                u64::from(r.borrow().flash.read_data(DATA_START + off as u32, size))
            }),
            Some(move |_: &mut Unicorn<()>, off: u64, size: usize, v: u64| {
                w.borrow_mut()
                    .flash
                    .write_data(DATA_START + off as u32, size, v as u32)
            }),
        )
        .map_err(uc_err)?;
        // Peripherals (APB1, APB2, AHB1) and the core's private space.
        for (base, size) in [(0x4000_0000u64, 0x8_0000u64), (0xE000_0000, 0x10_0000)] {
            let (r, w) = (bus.clone(), bus.clone());
            uc.mmio_map(
                base,
                size,
                Some(move |_: &mut Unicorn<()>, off: u64, size: usize| {
                    u64::from(r.borrow_mut().read((base + off) as u32, size))
                }),
                Some(move |_: &mut Unicorn<()>, off: u64, size: usize, v: u64| {
                    w.borrow_mut().write((base + off) as u32, size, v as u32)
                }),
            )
            .map_err(uc_err)?;
        }
        // Reset: SP and PC from the vector table.
        let mut vectors = [0u8; 8];
        uc.mem_read(FLASH_BASE, &mut vectors).map_err(uc_err)?;
        let sp = u32::from_le_bytes([vectors[0], vectors[1], vectors[2], vectors[3]]);
        let pc = u32::from_le_bytes([vectors[4], vectors[5], vectors[6], vectors[7]]);
        uc.reg_write(RegisterARM::SP, u64::from(sp))
            .map_err(uc_err)?;
        uc.reg_write(RegisterARM::PC, u64::from(pc & !1))
            .map_err(uc_err)?;
        // The core's exceptions: WFE (EXCP_YIELD) is a hint the architecture lets an
        // implementation treat as a no-op, and is so here (the executor's `sev` always
        // precedes it when work is pending); WFI (EXCP_HLT) stops the run — nothing
        // modelled would wake the core. Any other exception is recorded and stops it.
        let exceptions = Rc::new(RefCell::new(Vec::new()));
        let seen = exceptions.clone();
        uc.add_intr_hook(move |uc: &mut Unicorn<()>, intno: u32| {
            if intno != EXCP_YIELD {
                seen.borrow_mut().push(intno);
                let _ = uc.emu_stop();
            }
        })
        .map_err(uc_err)?;
        // unicorn reports WFE as an invalid instruction, with PC past it: the run goes on.
        uc.add_insn_invalid_hook(|uc: &mut Unicorn<()>| {
            let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let mut previous = [0u8; 2];
            pc >= 2
                && uc.mem_read(pc - 2, &mut previous).is_ok()
                && u16::from_le_bytes(previous) == WFE
        })
        .map_err(uc_err)?;
        let rtt = image.symbol("_SEGGER_RTT").map(|s| s.address);
        Ok(Self {
            uc,
            bus,
            rtt,
            exceptions,
            log: Vec::new(),
            instructions: 0,
            plant,
            timer_ticks: 0,
            apb1_ticks: 0,
            adc_ticks: 0,
            frames: FrameTiming::default(),
            clocks: None,
            latency_at_start: 0,
        })
    }

    /// The plant on the pins, if it is a `P`.
    pub fn plant<P: Plant + 'static>(&self) -> Option<&P> {
        self.plant.as_any().downcast_ref::<P>()
    }

    /// The core's registers, RAM, the peripherals' state and the clocks' counts, to
    /// [`restore`](Self::restore) (the plant is not rewound). O(RAM).
    pub fn snapshot(&self) -> Result<Snapshot> {
        let mut context = self.uc.context_alloc().map_err(uc_err)?;
        self.uc.context_save(&mut context).map_err(uc_err)?;
        let ram = [SRAM, CCM]
            .iter()
            .map(|&(base, size)| self.uc.mem_read_as_vec(base, size as usize).map_err(uc_err))
            .collect::<Result<Vec<_>>>()?;
        Ok(Snapshot {
            context,
            ram,
            bus: self.bus.borrow().clone(),
            counts: (
                self.instructions,
                self.timer_ticks,
                self.apb1_ticks,
                self.adc_ticks,
            ),
            frames: self.frames.clone(),
            log: self.log.len(),
        })
    }

    pub fn restore(&mut self, s: &Snapshot) -> Result<()> {
        self.uc.context_restore(&s.context).map_err(uc_err)?;
        for (&(base, _), bytes) in [SRAM, CCM].iter().zip(&s.ram) {
            self.uc.mem_write(base, bytes).map_err(uc_err)?;
        }
        *self.bus.borrow_mut() = s.bus.clone();
        (
            self.instructions,
            self.timer_ticks,
            self.apb1_ticks,
            self.adc_ticks,
        ) = s.counts;
        self.frames = s.frames.clone();
        self.log.truncate(s.log);
        Ok(())
    }

    /// Runs until the image sleeps, faults or exactly `limit` more instructions have run.
    pub fn run(&mut self, limit: u64) -> Result<RunEnd> {
        let stop_at = self.instructions + limit;
        while self.instructions < stop_at {
            let pc = self.uc.reg_read(RegisterARM::PC).map_err(uc_err)?;
            let count = (stop_at - self.instructions).min(CHUNK as u64) as usize;
            let result = self.uc.emu_start(pc | 1, u64::MAX, 0, count);
            let pc_after = self.uc.reg_read(RegisterARM::PC).map_err(uc_err)? as u32;
            if let Err(e) = result {
                return Ok(RunEnd::CoreFault {
                    pc: pc_after,
                    error: format!("{e:?}"),
                });
            }
            self.instructions += count as u64;
            if let Some(block) = self.rtt {
                let _ = crate::rtt::drain(&mut self.uc, block, &mut self.log);
            }
            if let Some(end) = self.step_peripherals()? {
                return Ok(end);
            }
            // WFI: the core sleeps until an interrupt, and none is modelled.
            let mut around = [0u8; 4];
            if pc_after >= 2
                && self
                    .uc
                    .mem_read(u64::from(pc_after - 2), &mut around)
                    .is_ok()
            {
                let before = u16::from_le_bytes([around[0], around[1]]);
                let at = u16::from_le_bytes([around[2], around[3]]);
                if before == WFI || at == WFI {
                    return Ok(RunEnd::Asleep { pc: pc_after });
                }
            }
            let raised = self.exceptions.borrow_mut().pop();
            match raised {
                Some(EXCP_HLT) => return Ok(RunEnd::Asleep { pc: pc_after }),
                Some(n) => {
                    return Ok(RunEnd::CoreFault {
                        pc: pc_after,
                        error: format!("exception {n:#x}"),
                    })
                }
                None => {}
            }
        }
        Ok(RunEnd::InstructionLimit)
    }

    fn step_peripherals(&mut self) -> Result<Option<RunEnd>> {
        let mut bus = self.bus.borrow_mut();
        bus.cycles = self.instructions;
        if let Some(u) = bus.unmodelled.first() {
            return Ok(Some(RunEnd::Unmodelled(*u)));
        }
        if bus.tim1.interrupts_enabled() != 0
            || bus.tim2.interrupts_enabled() != 0
            || bus.tim3.interrupts_enabled() != 0
        {
            return Ok(Some(RunEnd::InterruptEnabled("a timer's DIER")));
        }
        if bus.adc1.interrupts_enabled() != 0 || bus.adc2.interrupts_enabled() != 0 {
            return Ok(Some(RunEnd::InterruptEnabled("an ADC's CR1")));
        }
        // SysTick's counter with its interrupt.
        if bus.scs.read(0x10).unwrap_or(0) & 3 == 3 {
            return Ok(Some(RunEnd::InterruptEnabled("SysTick")));
        }
        let tree = match bus.rcc.tree() {
            Ok(t) => t,
            Err(_) => return Ok(None),
        };
        // Timer and ADC kernels in proportion to SYSCLK.
        let sysclk = u64::from(tree.sysclk.max(1));
        let timer_total =
            u128::from(self.instructions) * u128::from(tree.apb2_timers) / u128::from(sysclk);
        let timer_ticks = (timer_total as u64).saturating_sub(self.timer_ticks);
        self.timer_ticks = timer_total as u64;
        // TIM2 and TIM3 on APB1's timer clock, when they count it (the board slaves them).
        let apb1_total =
            u128::from(self.instructions) * u128::from(tree.apb1_timers) / u128::from(sysclk);
        let apb1_ticks = (apb1_total as u64).saturating_sub(self.apb1_ticks);
        self.apb1_ticks = apb1_total as u64;
        let adcpre = (bus.adc_common.read(ADC_CCR).unwrap_or(0) >> 16) & 3;
        let adc_hz = u64::from(tree.apb2) / (2 * (u64::from(adcpre) + 1));
        let adc_total = u128::from(self.instructions) * u128::from(adc_hz) / u128::from(sysclk);
        let adc_ticks = (adc_total as u64).saturating_sub(self.adc_ticks);
        self.adc_ticks = adc_total as u64;

        if self.clocks.is_none() && bus.tim1.raw(crate::timers::CR1) & 1 != 0 {
            self.clocks = Some(tree);
            self.latency_at_start = bus.flash.latency();
        }
        let events = bus.tim1.advance(timer_ticks);
        // Their own updates drive nothing here.
        let _ = (bus.tim2.advance(apb1_ticks), bus.tim3.advance(apb1_ticks));
        if events.updates > 0 {
            self.plant.sample();
        }
        bus.encoder_edges = self.plant.encoder_edges();
        bus.adc1.advance(adc_ticks);
        bus.adc2.advance(adc_ticks);
        if events.trgo > 0 {
            let plant = &self.plant;
            bus.adc1.start_injected(|ch| plant.volts(ch));
            bus.adc2.start_injected(|ch| plant.volts(ch));
            let edges = bus.encoder_edges;
            bus.tim3.follow_encoder(edges);
            bus.tim2.trigger(events.trgo);
            bus.tim3.trigger(events.trgo);
            self.frames.pending_counts =
                match (bus.adc1.pending_results(), bus.adc2.pending_results()) {
                    (Some(a), Some(b)) => Some(firmware::acquisition::Counts {
                        currents_and_transducer: a,
                        bus_and_temperature: [b[0], b[1]],
                        demand: b[2],
                        encoder: bus.tim3.raw(crate::timers::CCR1 + 8) as u16,
                    }),
                    _ => None,
                };
            self.frames.triggers += u64::from(events.trgo);
            self.frames.pending_trigger = Some(self.instructions);
            self.frames.pending_duties = Some((self.instructions, bus.tim1.compare_writes));
        }
        if events.updates > 0 {
            let arr = bus.tim1.active_arr().max(1) as f32;
            let tree_timers = tree.apb2_timers.max(1) as f32;
            let legs = core::array::from_fn(|ch| {
                let (ccr, on, on_n) = bus.tim1.compare(ch);
                (on && on_n && bus.tim1.main_output_enabled()).then(|| (ccr as f32 / arr).min(1.0))
            });
            let state = BridgeState {
                legs,
                dead_time: bus.tim1.dead_time_ticks() as f32 / tree_timers,
                main_output: bus.tim1.main_output_enabled(),
            };
            drop(bus);
            self.plant.drive(&state);
            bus = self.bus.borrow_mut();
        }
        // The frame's duties: all three legs' compare registers written since the trigger.
        if let Some((at, writes)) = self.frames.pending_duties {
            if bus.tim1.compare_writes >= writes + 3 {
                self.frames.to_duties.push(self.instructions - at);
                self.frames.pending_duties = None;
            }
        }
        // The frame's read: the image clears ADC1's JEOC after reading JDR1…4.
        if let Some(at) = self.frames.pending_trigger {
            if bus.adc1.read(crate::adc::SR).unwrap_or(0) & (1 << 2) == 0 && bus.adc1.pending_done()
            {
                self.frames.latencies.push(self.instructions - at);
                self.frames.pending_trigger = None;
                if let Some(counts) = self.frames.pending_counts.take() {
                    self.frames.fed.push(counts);
                }
            }
        }
        Ok(None)
    }
}
