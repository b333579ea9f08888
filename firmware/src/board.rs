//! The board image (feature `hardware`): the preflight on the STM32F405's own peripherals,
//! through embassy-stm32, with its report over RTT (defmt).
//!
//! - Clocks: 8 MHz crystal, PLL to 168 MHz; APB2 84 MHz (timers 168 MHz), APB1 42 MHz
//!   (timers 84 MHz).
//! - Bridge: TIM1, complementary PWM on PA8/PB13, PA9/PB14, PA10/PB15, counting up and down
//!   at the record's carrier with its dead time ([`firmware::bridge::BridgeTiming`]); the
//!   update event once per control period at the counter's top, every leg low there; TRGO =
//!   update. Legs off: both outputs at their inactive level (OSSR).
//! - ADC trigger: TIM1 TRGO starts ADC1's injected ranks (PA0–PA2 the phase currents, PA3 the
//!   surface transducer) and ADC2's (PC0 the bus divider, PC1 the winding thermistor), 15
//!   cycles each at 21 MHz: 5 µs after the trigger both are done.
//! - Encoder: TIM3 in encoder mode on PA6/PA7; channel 3 captures its count on TIM1 TRGO (TRC
//!   = ITR0), the same instant as the ADC.
//! - Trigger count: TIM2 counts TIM1 TRGO (external clock mode 1 on ITR0), so a frame taken
//!   late is an overrun, never a silent gap ([`firmware::acquisition::pace`]).
//! - Flash: the actuator record and the health log's image each in an A/B pair of 128 KiB
//!   sectors ([`firmware::storage::AbStore`], `StorageLayout::STM32F405`: sectors 5–6 and
//!   9–10). The checkpoint pair (7–8) is not used: a GA checkpoint resumes only on the same
//!   measured test, and the board re-runs the test after a power cut (the 22 kB measurement is
//!   not kept in flash).
//!
//! - Tests: a test a gust spoiled is played again (`Reruns`), and where a trusted first
//!   test's noise calls for more (`ActuatorRecord::tests_called_for`, at most the record's
//!   `max_tests`) so is the test, each reading added to the health record's mean
//!   (`shared::repeat::RepeatedTests`, kept beside the uncertainty runs).
//!
//! Work per executor turn: one preflight poll (during the test: the frames due, each O(1)
//! with one sequencer tick; then ≤ `evaluations_per_poll` evaluations) and one heartbeat.
//! The test's frames must be taken within one control period of their trigger: an overrun
//! ends the test with the bridge off. Nothing here has run on a board (QEMU's STM32F405 has
//! none of these peripherals); the library parts it drives are tested on the host.

use core::sync::atomic::{AtomicU32, Ordering};

use defmt_rtt as _;
use embassy_executor::{Executor, Spawner};
use embassy_stm32::flash::Flash;
use embassy_stm32::gpio::Flex;
use embassy_stm32::gpio::OutputType;
use embassy_stm32::pac;
use embassy_stm32::pac::adc::vals::{Exten, SampleTime};
use embassy_stm32::pac::timer::vals::{CcmrInputCcs, Ckd, Mms, Ossr, Sms, Ts};
use embassy_stm32::peripherals::TIM1;
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::complementary_pwm::ComplementaryPwmPin;
use embassy_stm32::timer::low_level::{CountingMode, OutputCompareMode, Timer};
use embassy_stm32::timer::qei::Qei;
use embassy_stm32::timer::simple_pwm::PwmPin;
use embassy_stm32::timer::{Ch1, Ch2, Ch3, Channel};
use embassy_stm32::Config;
use static_cell::{ConstStaticCell, StaticCell};

use core::future::Future;
use core::pin::{pin, Pin};

use firmware::acquisition::{pace, Converter, Counts, Pace, SensorScaling};
use firmware::bridge::{BridgeDrive, BridgeTiming, Leg, Legs};
use firmware::cooperate::yield_now;
use firmware::flight::{
    print_window_bits, read_window, CommandedSource, FlightCommand, KeptCommand, Scratch, Slices,
    WindowAcquisition, WindowOutcome, WindowRead, MAX_WINDOWS,
};
use firmware::health::{preflight_flight, record_entry, test_record};
use firmware::position_loop::Sensing;
use firmware::sequencer::{Sequenced, TestSequencer};
use firmware::storage::{AbStore, StorageLayout};
use firmware::{Acquired, CurrentSource, Preflight, PreflightSettings, Progress, Report, Reruns};
use shared::actuator::{ActuatorRecord, RECORD_BYTES};
use shared::domain::Domain;
use shared::fdi::OnboardMeasured;
use shared::fusion::{WindowFusion, FLIGHT_MAX_FRICTION_STD};
use shared::health::{HealthRecord, RamStore, RecordedDay, ONBOARD_RECORDS};
use shared::magnets::WeakMagnet;
use shared::prognosis::TrendSettings;
use shared::window::HeldComponents;
use shared::LowPass;

/// The bridge timer's clock [Hz] (APB2 × 2).
const TIMER_HZ: u32 = 168_000_000;

static MEASURED: ConstStaticCell<OnboardMeasured> = ConstStaticCell::new(OnboardMeasured::ZEROED);
/// The preflight's uncertainty runs, then a window's kept command: never both at once.
static SCRATCH: ConstStaticCell<Scratch> = ConstStaticCell::new(Scratch::IDLE);
static HEALTH_STORE: ConstStaticCell<RamStore<ONBOARD_RECORDS>> =
    ConstStaticCell::new(RamStore::ZEROED);

/// Heartbeat task runs (the flight software's share of the CPU).
static BEATS: AtomicU32 = AtomicU32::new(0);

/// Frames read since power-up (each trigger's conversions the image took): a window's first
/// frame is reported by this count.
static FRAMES_READ: AtomicU32 = AtomicU32::new(0);

/// Frames the board waits after its preflight for the flight control computer's demand
/// (0.1 s): a flight that follows at once is flown; otherwise the image is done.
const FLIGHT_WAIT_FRAMES: u32 = 1_000;

/// Frames the position loop follows the demand before a flight's first window (0.5 s).
const SETTLE_FRAMES: u32 = 5_000;

/// The board's flash (blocking: the F405's single bank stalls code fetch while it writes).
type BoardFlash = Flash<'static, embassy_stm32::flash::Blocking>;

/// Why the board stopped before or during the test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
enum BoardError {
    /// The frames fell behind the trigger: `missed` conversions were not taken.
    Overrun { missed: u32 },
    /// The first update event did not come at the counter's top.
    TriggerPhase,
    /// The demand went (the flight ended) during a window's frames.
    Landed,
}

/// The bridge's legs in TIM1: a duty in CCRx with both outputs enabled, or both disabled
/// (inactive level, OSSR = 1). Takes effect at the next update (preload).
struct TimerLegs;

impl Legs for TimerLegs {
    fn set(&mut self, legs: [Leg; 3]) {
        let tim = pac::TIM1;
        for (channel, leg) in legs.into_iter().enumerate() {
            let (on, duty) = match leg {
                Leg::Off => (false, 0),
                Leg::Duty(d) => (true, d),
            };
            tim.ccr(channel).write(|w| w.set_ccr(duty));
            tim.ccer().modify(|w| {
                w.set_cce(channel, on);
                w.set_ccne(channel, on);
            });
        }
    }
}

/// Every leg off, the main output disabled: the safe state after the test or a fault.
fn bridge_off() {
    TimerLegs.set([Leg::Off; 3]);
    pac::TIM1.bdtr().modify(|w| w.set_moe(false));
}

/// Frames from the board's converters, commanding the test one control period per frame.
/// Each test (a re-run too) is paced from the triggers counted since it began, with the
/// bridge's outputs enabled again; the encoder's count continues across tests (its zero is
/// the first test's: the electrical zero the board was aligned to).
struct BoardSource<'a> {
    sequencer: TestSequencer,
    drive: BridgeDrive<TimerLegs>,
    converter: &'a mut Converter,
    frames: u32,
    /// TIM2's trigger count when the test began.
    start: u32,
}

impl<'a> BoardSource<'a> {
    /// A test from the next trigger on, the bridge's outputs enabled, every leg off; the
    /// converters' flags left from before (a re-run's: the first test's identification ran
    /// under the triggers) cleared while that trigger's conversions run ([`fresh_trigger`]).
    /// At most one control period.
    fn begin(
        sequencer: TestSequencer,
        drive: BridgeDrive<TimerLegs>,
        converter: &'a mut Converter,
    ) -> Self {
        TimerLegs.set([Leg::Off; 3]);
        pac::TIM1.bdtr().modify(|w| w.set_moe(true));
        Self {
            sequencer,
            drive,
            converter,
            frames: 0,
            start: fresh_trigger().wrapping_sub(1),
        }
    }

    fn counts() -> Counts {
        let adc1 = pac::ADC1;
        let adc2 = pac::ADC2;
        let counts = Counts {
            currents_and_transducer: core::array::from_fn(|i| adc1.jdr(i).read().jdata()),
            bus_and_temperature: core::array::from_fn(|i| adc2.jdr(i).read().jdata()),
            demand: adc2.jdr(2).read().jdata(),
            encoder: pac::TIM3.ccr(2).read().ccr(),
        };
        FRAMES_READ.fetch_add(1, Ordering::Relaxed);
        for adc in [adc1, adc2] {
            adc.sr().modify(|w| {
                w.set_jeoc(false);
                w.set_jstrt(false);
            });
        }
        counts
    }
}

impl CurrentSource for BoardSource<'_> {
    type Error = BoardError;

    fn next_frame(&mut self) -> Result<Acquired, BoardError> {
        if self.frames as usize >= self.sequencer.samples() {
            bridge_off();
            return Ok(Acquired::EndOfTest);
        }
        match pace(pac::TIM2.cnt().read().wrapping_sub(self.start), self.frames) {
            Pace::Wait => return Ok(Acquired::NotYet),
            Pace::Overrun { missed } => {
                bridge_off();
                return Err(BoardError::Overrun { missed });
            }
            Pace::Due => {}
        }
        if !(pac::ADC1.sr().read().jeoc() && pac::ADC2.sr().read().jeoc()) {
            return Ok(Acquired::NotYet);
        }
        let (frame, feedback) = self.converter.convert(&Self::counts());
        self.drive.measured(feedback);
        if self.sequencer.tick(&mut self.drive) == Sequenced::Done {
            bridge_off();
        }
        self.frames += 1;
        Ok(Acquired::Frame(frame))
    }
}

/// Waits for the next trigger and clears the converters' end-of-conversion flags while its
/// conversions run (5 µs): a flag left from a trigger no frame was taken for (the preflight's
/// identification, the health step) would have the next frame read a conversion early, and
/// every frame after it one period stale against its encoder capture. Returns the trigger's
/// count: its frame is the first to take. At most one control period.
fn fresh_trigger() -> u32 {
    let tim2 = pac::TIM2;
    let before = tim2.cnt().read();
    let mut now = before;
    while now == before {
        now = tim2.cnt().read();
    }
    for adc in [pac::ADC1, pac::ADC2] {
        adc.sr().modify(|w| {
            w.set_jeoc(false);
            w.set_jstrt(false);
        });
    }
    now
}

/// Peripherals set up for the test.
struct Hardware {
    flash: BoardFlash,
    /// Kept: dropping them would release their pins and clocks.
    _bridge: Timer<'static, embassy_stm32::peripherals::TIM1>,
    _encoder: Qei<'static, embassy_stm32::peripherals::TIM3>,
    _trigger_count: Timer<'static, embassy_stm32::peripherals::TIM2>,
}

fn clocks() -> Config {
    use embassy_stm32::rcc::{
        AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv, PllQDiv,
        PllSource, Sysclk,
    };
    let mut config = Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz(8_000_000),
        mode: HseMode::Oscillator,
    });
    config.rcc.pll_src = PllSource::HSE;
    config.rcc.pll = Some(Pll {
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL168,
        divp: Some(PllPDiv::DIV2),
        divq: Some(PllQDiv::DIV7),
        divr: None,
    });
    config.rcc.ahb_pre = AHBPrescaler::DIV1;
    config.rcc.apb1_pre = APBPrescaler::DIV4;
    config.rcc.apb2_pre = APBPrescaler::DIV2;
    config.rcc.sys = Sysclk::PLL1_P;
    config
}

/// Starts the clocks, reads the actuator record from its flash pair, sets up the converters,
/// the encoder, the trigger count and the bridge (outputs off) for the record's drive, and
/// starts the carrier.
fn start() -> Result<(ActuatorRecord, BridgeTiming, Hardware), Stop> {
    let p = embassy_stm32::init(clocks());
    // The core's cycle counter times the flight's slices.
    let mut core = cortex_m::Peripherals::take().ok_or(Stop::StartUp)?;
    core.DCB.enable_trace();
    core.DWT.enable_cycle_counter();
    let mut flash = Flash::new_blocking(p.FLASH);
    let (a, b) = StorageLayout::pair(&StorageLayout::STM32F405.record);
    let record = {
        let mut bytes = [0u8; RECORD_BYTES];
        let mut records = AbStore::new(&mut flash, a, b).map_err(|_| Stop::Flash)?;
        let n = records
            .read(&mut bytes)
            .map_err(|_| Stop::Flash)?
            .ok_or(Stop::NoRecord)?;
        ActuatorRecord::decode(bytes.get(..n).unwrap_or(&[])).map_err(Stop::RecordRefused)?
    };
    let timing = BridgeTiming::new(&record.drive, TIMER_HZ, record.params.control_period)
        .map_err(Stop::Bridge)?;

    converters_on();
    // ADC1: the phase currents and the transducer; ADC2: bus, temperature and the flight
    // control computer's demand; both on TRGO.
    // Through the PAC: the HAL's ADC start-up links 1 kB of 64-bit division for a delay.
    for mut pin in [
        Flex::new(p.PA0),
        Flex::new(p.PA1),
        Flex::new(p.PA2),
        Flex::new(p.PA3),
        Flex::new(p.PC0),
        Flex::new(p.PC1),
        Flex::new(p.PC2),
    ] {
        pin.set_as_analog();
        // Analog from here on; dropping the handle would disconnect the pin.
        core::mem::forget(pin);
    }
    injected_ranks(pac::ADC1, &[0, 1, 2, 3]);
    injected_ranks(pac::ADC2, &[10, 11, 12]);

    // Encoder on TIM3, its count captured on channel 3 from TRC = ITR0 (TIM1 TRGO).
    let encoder = Qei::new(p.TIM3, p.PA6, p.PA7, Default::default());
    let tim3 = pac::TIM3;
    tim3.smcr().modify(|w| w.set_ts(Ts::ITR0));
    tim3.ccmr_input(1)
        .modify(|w| w.set_ccs(0, CcmrInputCcs::TRC));
    tim3.ccer().modify(|w| w.set_cce(2, true));

    // TIM2 counts the triggers.
    let trigger_count = Timer::new(p.TIM2);
    let tim2 = pac::TIM2;
    tim2.smcr().modify(|w| {
        w.set_ts(Ts::ITR0);
        w.set_sms(Sms::EXT_CLOCK_MODE);
    });
    tim2.cnt().write_value(0);
    tim2.cr1().modify(|w| w.set_cen(true));

    // The bridge: the pins in their timer function (kept so from here on), the timer
    // centre-aligned, PWM mode 1 with preload on every channel, the record's dead time.
    let push_pull = OutputType::PushPull;
    core::mem::forget(PwmPin::<TIM1, Ch1>::new(p.PA8, push_pull));
    core::mem::forget(ComplementaryPwmPin::<TIM1, Ch1>::new(p.PB13, push_pull));
    core::mem::forget(PwmPin::<TIM1, Ch2>::new(p.PA9, push_pull));
    core::mem::forget(ComplementaryPwmPin::<TIM1, Ch2>::new(p.PB14, push_pull));
    core::mem::forget(PwmPin::<TIM1, Ch3>::new(p.PA10, push_pull));
    core::mem::forget(ComplementaryPwmPin::<TIM1, Ch3>::new(p.PB15, push_pull));
    let bridge = Timer::new(p.TIM1);
    bridge.set_counting_mode(CountingMode::CenterAlignedDownInterrupts);
    for channel in [Channel::Ch1, Channel::Ch2, Channel::Ch3] {
        bridge.set_output_compare_mode(channel, OutputCompareMode::PwmMode1);
        bridge.set_output_compare_preload(channel, true);
    }
    bridge.set_autoreload_preload(true);
    bridge.set_dead_time_clock_division(Ckd::DIV1);
    bridge.set_dead_time_value(timing.dead_time_register());
    let tim1 = pac::TIM1;
    // Stop, set the carrier's counts and the repetition before the counter starts (so the
    // update falls on the overflow), reload, start.
    tim1.cr1().modify(|w| w.set_cen(false));
    TimerLegs.set([Leg::Off; 3]);
    tim1.arr().write(|w| w.set_arr(timing.counts));
    tim1.rcr()
        .write(|w| w.set_rep(u16::from(timing.repetition)));
    tim1.cr2().modify(|w| w.set_mms(Mms::UPDATE));
    tim1.bdtr().modify(|w| {
        w.set_ossr(Ossr::IDLE_LEVEL);
        w.set_moe(true);
    });
    tim1.cnt().write(|w| w.set_cnt(0));
    tim1.egr().write(|w| w.set_ug(true));
    tim1.sr().modify(|w| w.set_uif(false));
    tim2.cnt().write_value(0);
    tim1.cr1().modify(|w| w.set_cen(true));
    // The first update: the counter must be turning down (at its top).
    while !tim1.sr().read().uif() {}
    if tim1.cr1().read().dir() != pac::timer::vals::Dir::DOWN {
        bridge_off();
        return Err(Stop::Board(BoardError::TriggerPhase));
    }
    let hardware = Hardware {
        flash,
        _bridge: bridge,
        _encoder: encoder,
        _trigger_count: trigger_count,
    };
    Ok((record, timing, hardware))
}

/// ADC clock: APB2 (84 MHz) / 4 = 21 MHz, within the converter's 36 MHz.
fn converters_on() {
    pac::RCC.apb2enr().modify(|w| {
        w.set_adc1en(true);
        w.set_adc2en(true);
    });
    pac::ADC123_COMMON
        .ccr()
        .modify(|w| w.set_adcpre(pac::adccommon::vals::Adcpre::DIV4));
}

/// `adc`'s injected ranks: `channels` in order (at most 4), 15 cycles each, converted on
/// TIM1 TRGO's rising edge, read from JDR1 on.
fn injected_ranks(adc: pac::adc::Adc, channels: &[u8]) {
    let n = channels.len().min(4);
    adc.cr2().modify(|w| w.set_adon(true));
    // tSTAB: 3 µs at 168 MHz.
    cortex_m::asm::delay(3 * 168);
    adc.cr1().modify(|w| w.set_scan(true));
    adc.jsqr().modify(|w| w.set_jl(n.saturating_sub(1) as u8));
    for (rank, &channel) in channels.iter().take(n).enumerate() {
        let at = usize::from(channel);
        if at < 10 {
            adc.smpr2().modify(|w| w.set_smp(at, SampleTime::CYCLES15));
        } else {
            adc.smpr1()
                .modify(|w| w.set_smp(at - 10, SampleTime::CYCLES15));
        }
        // With fewer than 4 ranks the sequence sits at the top of JSQR (RM0090 §13.13.12).
        adc.jsqr().modify(|w| w.set_jsq(rank + (4 - n), channel));
    }
    adc.cr2().modify(|w| {
        w.set_jextsel(TIM1_TRGO_INJECTED);
        w.set_jexten(Exten::RISING_EDGE);
    });
}

/// JEXTSEL of TIM1 TRGO (RM0090 §13.13.3).
const TIM1_TRGO_INJECTED: u8 = 0b0001;

/// Stands in for the flight software's other tasks: counts its turns (reported at the end).
#[embassy_executor::task]
async fn heartbeat() {
    loop {
        BEATS.fetch_add(1, Ordering::Relaxed);
        yield_now().await;
    }
}

/// Starts the executor with the preflight task. Written out rather than
/// `#[embassy_executor::main]`, whose `unwrap` on the spawn keeps `core::fmt` in the image.
#[cortex_m_rt::entry]
fn main() -> ! {
    static EXECUTOR: StaticCell<Executor> = StaticCell::new();
    EXECUTOR
        .init(Executor::new())
        .run(|spawner| match preflight_task(spawner) {
            Ok(token) => spawner.spawn(token),
            Err(_) => defmt::error!("cannot spawn the preflight task"),
        })
}

#[embassy_executor::task]
async fn preflight_task(spawner: Spawner) {
    let outcome = preflight(spawner).await;
    bridge_off();
    match outcome {
        Ok(()) => defmt::println!("preflight done"),
        Err(e) => defmt::error!("preflight not done: {}", e),
    }
    loop {
        cortex_m::asm::wfi();
    }
}

/// Why the preflight did not report.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
enum Stop {
    /// The record pair holds no record (`host-sim flash-pair --store record --write`).
    NoRecord,
    /// The record is damaged, of another version or out of range.
    RecordRefused(shared::actuator::ActuatorRecordError),
    /// The record's drive cannot run on the bridge timer.
    Bridge(firmware::bridge::BridgeError),
    Board(BoardError),
    /// The preflight failed (logged with its stage and reason).
    Preflight,
    /// A flash pair could not be opened, read or written.
    Flash,
    /// The health step refused the record (e.g. the log already holds a later flight).
    Health,
    /// A static buffer was taken twice, or the heartbeat could not be spawned.
    StartUp,
}

async fn preflight(spawner: Spawner) -> Result<(), Stop> {
    let (Some(measured), Some(scratch), Some(store)) = (
        MEASURED.try_take(),
        SCRATCH.try_take(),
        HEALTH_STORE.try_take(),
    ) else {
        return Err(Stop::StartUp);
    };
    let (record, timing, mut hw) = start()?;
    let (curvature, tests) = scratch.curvature().ok_or(Stop::StartUp)?;
    let layout = StorageLayout::STM32F405;
    let params = record.params;
    let settings = PreflightSettings::ONBOARD.for_actuator(&record);
    let filter = LowPass::for_control_period(params.control_period).map_err(|_| Stop::StartUp)?;
    measured.set_filter(filter);
    let sequencer = TestSequencer::new(record.test, params.control_period);
    spawner.spawn(heartbeat().map_err(|_| Stop::StartUp)?);
    defmt::info!(
        "preflight: {=usize} frames, carrier {=u16} counts, dead time {=u16} ticks",
        sequencer.samples(),
        timing.counts,
        timing.dead_time_ticks
    );

    // No GA checkpoint here: a power cut re-runs the test, and a checkpoint resumes only on
    // the same measured test (its fingerprint), which the board does not keep in flash.
    // A test whose load moved (a gust on the parked surface) is run again, a bounded number
    // of times (`Reruns`). Where the first read test's noise calls for more
    // (`ActuatorRecord::tests_called_for`, at most the record's `max_tests`), the test is
    // played again and each reading added to the preflight's record; the flight's windows
    // hold the last test's reading.
    let mut reruns = Reruns::new();
    let mut converter = Converter::new(SensorScaling::REFERENCE_BOARD);
    let (report, _) = loop {
        let source = BoardSource::begin(
            sequencer,
            BridgeDrive::new(
                TimerLegs,
                timing,
                settings.actuator.drive,
                &settings.actuator.params,
                Sensing::BOARD,
            ),
            &mut converter,
        );
        let mut preflight = Preflight::new(&settings, source, &mut *measured)
            .with_curvature_buffer(&mut *curvature);
        let mut stage = preflight.stage();
        let report = loop {
            match preflight.poll() {
                Ok(Progress::Finished(report)) => break report,
                Ok(Progress::Working { stage: next }) => stage = next,
                Err(e) => {
                    bridge_off();
                    defmt::error!("preflight failed in stage {}: {}", stage, e);
                    return Err(Stop::Preflight);
                }
            }
            // One yield per poll: during the test a frame is due every control period, so
            // the other tasks' turns must stay short.
            yield_now().await;
        };
        let day = RecordedDay::of(preflight.day());
        if reruns.again(&report) {
            defmt::println!(
                "test {=u8} spoiled: {}; run again",
                reruns.tests(),
                report.domain
            );
            continue;
        }
        tests.add(&test_record(0, &report, day));
        let (played, called) = (tests.played(), tests.called_for(&settings.actuator));
        if played >= called {
            break (report, day);
        }
        defmt::println!(
            "test {=u32} of {=u32}: the noise calls for more",
            played,
            called
        );
    };

    let r = &report.result;
    defmt::println!(
        "result faults={} fitness={=f32} domain={}",
        r.faults,
        r.fitness,
        report.domain
    );
    defmt::println!("verdicts={}", report.verdicts);
    defmt::println!(
        "magnets depth={=f32} centre={=f32} pole={=u32} assessment={}",
        r.magnets.depth,
        r.magnets.centre,
        r.magnets.pole(&settings.actuator.params),
        report.magnet
    );

    // The health log: its image from the pair, this preflight appended, the image back.
    let (a, b) = StorageLayout::pair(&layout.health);
    let flight = {
        let mut pair = AbStore::new(&mut hw.flash, a, b).map_err(|_| Stop::Flash)?;
        // Nothing stored: a new log. A pair that cannot be read is left as it is (no record
        // appended) rather than replaced by a log of one.
        store.erase();
        // A log kept before record version 4 is shorter: carried over in place.
        if let Some(len) = pair.read(store.as_bytes_mut()).map_err(|_| Stop::Flash)? {
            store.upgrade_read(len);
        }
        let entry = |newest| {
            let mut r = tests.reading();
            r.flight = preflight_flight(None, newest);
            r
        };
        let update = match record_entry(store, entry, &TrendSettings::DEFAULT) {
            Ok(u) => u,
            Err(e) => {
                defmt::error!("health record not appended: {}", e);
                return Err(Stop::Health);
            }
        };
        pair.write(store.as_bytes()).map_err(|_| Stop::Flash)?;
        defmt::println!(
            "health flight={=u32} records={=u32} beats={=u32}",
            update.record.flight,
            update.records,
            BEATS.load(Ordering::Relaxed)
        );
        update.record.flight
    };

    // The flight that follows: its windows read in the control loop's idle time, its reading
    // logged after it as the same flight's in-flight entry.
    let drive = BridgeDrive::new(
        TimerLegs,
        timing,
        settings.actuator.drive,
        &settings.actuator.params,
        Sensing::BOARD,
    );
    let mut control = FlightControl::new(drive, &mut converter, &settings.actuator);
    let kept = scratch.command().ok_or(Stop::StartUp)?;
    let Some(flown) = fly(&mut control, &settings, &report, measured, kept).await else {
        defmt::println!("no in-flight entry");
        return Ok(());
    };
    bridge_off();
    let entry = |_| {
        HealthRecord::of_flight_reading(
            flight,
            &flown.reading,
            flown.fitness_sum,
            flown.entered,
            flown.day,
            &flown.magnets,
        )
    };
    let update = match record_entry(store, entry, &TrendSettings::DEFAULT) {
        Ok(u) => u,
        Err(e) => {
            defmt::error!("in-flight health record not appended: {}", e);
            return Err(Stop::Health);
        }
    };
    AbStore::new(&mut hw.flash, a, b)
        .and_then(|mut pair| pair.write(store.as_bytes()))
        .map_err(|_| Stop::Flash)?;
    defmt::println!(
        "health flight={=u32} kind=in-flight records={=u32} beats={=u32}",
        update.record.flight,
        update.records,
        BEATS.load(Ordering::Relaxed)
    );
    Ok(())
}

/// Where the flight stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
enum FlightState {
    /// Waiting for the demand, `frames` more frames at most; the bridge off.
    Waiting {
        frames: u32,
    },
    Flying,
    /// The demand went: the flight is over, the bridge off.
    Landed,
    /// The control loop stopped (an overrun): the bridge off.
    Stopped(BoardError),
}

/// The flight on the board: each control period's frame (paced from the flight's first
/// trigger), the demand followed through the position loop, a window's chirp superimposed
/// ([`FlightCommand`]), a window's frames handed to its acquisition ([`CommandedSource`]).
/// O(1) per frame: one conversion, one position-loop step.
struct FlightControl<'a> {
    drive: BridgeDrive<TimerLegs>,
    converter: &'a mut Converter,
    command: FlightCommand,
    scaling: SensorScaling,
    test: shared::test_design::PreflightTest,
    period: f32,
    state: FlightState,
    frames: u32,
    /// TIM2's trigger count when the flight control began.
    start: u32,
    /// The command acting in the last frame's period [rad].
    acting: f32,
    /// A window's frames taken, and its length.
    window: Option<(u32, u32)>,
}

impl<'a> FlightControl<'a> {
    /// From the next trigger on, waiting for the demand.
    fn new(
        drive: BridgeDrive<TimerLegs>,
        converter: &'a mut Converter,
        record: &ActuatorRecord,
    ) -> Self {
        Self {
            drive,
            converter,
            command: FlightCommand::follow(record.params.control_period),
            scaling: SensorScaling::REFERENCE_BOARD,
            test: record.test.chirp_only(),
            period: record.params.control_period,
            state: FlightState::Waiting {
                frames: FLIGHT_WAIT_FRAMES,
            },
            frames: 0,
            start: fresh_trigger().wrapping_sub(1),
            acting: 0.0,
            window: None,
        }
    }

    /// The frame due, if one is, with the command acting in its period; in flight the next
    /// period commanded. O(1).
    fn take(&mut self) -> Result<Option<shared::AdcFrame>, BoardError> {
        if matches!(self.state, FlightState::Landed | FlightState::Stopped(_)) {
            return Ok(None);
        }
        match pace(pac::TIM2.cnt().read().wrapping_sub(self.start), self.frames) {
            Pace::Wait => return Ok(None),
            Pace::Overrun { missed } => {
                bridge_off();
                self.state = FlightState::Stopped(BoardError::Overrun { missed });
                return Err(BoardError::Overrun { missed });
            }
            Pace::Due => {}
        }
        if !(pac::ADC1.sr().read().jeoc() && pac::ADC2.sr().read().jeoc()) {
            return Ok(None);
        }
        let counts = BoardSource::counts();
        self.frames = self.frames.wrapping_add(1);
        let (frame, feedback) = self.converter.convert(&counts);
        let demand = self.scaling.demand(counts.demand);
        match (self.state, demand) {
            (FlightState::Waiting { frames }, None) => {
                self.state = match frames.checked_sub(1) {
                    Some(0) | None => FlightState::Landed,
                    Some(left) => FlightState::Waiting { frames: left },
                };
                Ok(None)
            }
            (_, None) => {
                bridge_off();
                self.state = FlightState::Landed;
                Ok(None)
            }
            (_, Some(demand)) => {
                if self.state != FlightState::Flying {
                    TimerLegs.set([Leg::Off; 3]);
                    pac::TIM1.bdtr().modify(|w| w.set_moe(true));
                    self.state = FlightState::Flying;
                }
                self.drive.measured(feedback);
                self.acting = self.command.tick(demand, &mut self.drive);
                Ok(Some(frame))
            }
        }
    }

    /// Outside a window: the frame due taken and followed, nothing kept. O(1).
    fn serve(&mut self) {
        if self.window.is_none() {
            // An overrun is kept in the state (the bridge off) and reported at the end.
            let _ = self.take();
        }
    }

    fn flying(&self) -> bool {
        self.state == FlightState::Flying
    }

    fn waiting(&self) -> bool {
        matches!(self.state, FlightState::Waiting { .. })
    }

    /// A window's chirp from the next frame on, its frames for its acquisition.
    fn begin_window(&mut self) {
        self.command.begin_window(self.test, self.period);
        let samples = TestSequencer::new(self.test, self.period).samples();
        self.window = Some((0, u32::try_from(samples).unwrap_or(u32::MAX)));
    }
}

impl CurrentSource for FlightControl<'_> {
    type Error = BoardError;

    fn next_frame(&mut self) -> Result<Acquired, BoardError> {
        let Some((taken, samples)) = self.window else {
            return Ok(Acquired::EndOfTest);
        };
        if taken >= samples {
            self.window = None;
            return Ok(Acquired::EndOfTest);
        }
        match self.take() {
            Ok(Some(frame)) => {
                self.window = Some((taken.saturating_add(1), samples));
                Ok(Acquired::Frame(frame))
            }
            Ok(None) if self.flying() => Ok(Acquired::NotYet),
            Ok(None) => {
                self.window = None;
                Err(BoardError::Landed)
            }
            Err(e) => {
                self.window = None;
                Err(e)
            }
        }
    }
}

impl CommandedSource for FlightControl<'_> {
    /// The command acting in the last frame's period as a trace of the window holds it: the
    /// host reads the same window from the trace written of it.
    fn command(&self) -> f32 {
        shared::trace::command_as_traced(self.acting)
    }

    fn is_window(&self) -> bool {
        self.window.is_some()
    }
}

/// A window's reading in the control loop's idle time: one poll per slice, timed by the
/// core's cycle counter, and the control period due served after each.
struct FlightSlices<'c, 'a> {
    control: &'c mut FlightControl<'a>,
    slices: u32,
    /// The longest slice [core cycles; instructions under the board emulator].
    worst: u32,
}

impl Slices for FlightSlices<'_, '_> {
    async fn run<F: Future>(&mut self, mut future: Pin<&mut F>) -> F::Output {
        core::future::poll_fn(|cx| {
            let start = cortex_m::peripheral::DWT::cycle_count();
            let poll = future.as_mut().poll(cx);
            let took = cortex_m::peripheral::DWT::cycle_count().wrapping_sub(start);
            self.worst = self.worst.max(took);
            self.slices = self.slices.saturating_add(1);
            self.control.serve();
            poll
        })
        .await
    }
}

/// What a flight's windows read.
struct Flown {
    reading: shared::fusion::FlightReading,
    fitness_sum: f32,
    entered: u32,
    day: RecordedDay,
    /// The weak magnet the windows held (the preflight's).
    magnets: WeakMagnet,
}

/// The flight that follows the preflight, if its demand comes within
/// [`FLIGHT_WAIT_FRAMES`]: the demand followed, [`SETTLE_FRAMES`] of it, then up to
/// [`MAX_WINDOWS`] windows, each played, acquired and read in the control loop's idle time
/// holding what the preflight read; the demand followed until it goes (the flight's end).
/// `None`: no flight, or no reading (logged).
async fn fly(
    control: &mut FlightControl<'_>,
    settings: &PreflightSettings,
    report: &Report,
    measured: &mut OnboardMeasured,
    kept: &mut KeptCommand,
) -> Option<Flown> {
    while control.waiting() || (control.flying() && control.frames < SETTLE_FRAMES) {
        control.serve();
        yield_now().await;
    }
    if !control.flying() {
        return None;
    }
    defmt::println!(
        "flight begins at frame {=u32}",
        FRAMES_READ.load(Ordering::Relaxed)
    );
    let held = if report.domain == Domain::Within {
        report.held
    } else {
        HeldComponents::NONE
    };
    let record = ActuatorRecord {
        test: settings.actuator.test.chirp_only(),
        ..settings.actuator
    };
    let mut fusion = WindowFusion::EMPTY;
    let (mut read, mut entered, mut fitness_sum, mut first_day) = (0u32, 0u32, 0.0f32, None);
    let (mut slices, mut worst) = (0u32, 0u32);
    for n in 1..=MAX_WINDOWS as u32 {
        if !control.flying() {
            break;
        }
        control.begin_window();
        let first_frame = FRAMES_READ.load(Ordering::Relaxed);
        let acquired = match WindowAcquisition::start(
            &*control,
            record.test,
            record.params.pole_pairs,
            measured,
            kept,
        ) {
            Ok(mut acquisition) => loop {
                match acquisition.poll(control, measured, kept, 1) {
                    Ok(false) => yield_now().await,
                    Ok(true) => break Ok(acquisition.frames()),
                    Err(e) => break Err(e),
                }
            },
            Err(e) => Err(e),
        };
        let frames = match acquired {
            Ok(f) => f,
            Err(e) => {
                defmt::println!("window n={=u32} not acquired: {}", n, e);
                break;
            }
        };
        let mut window = FlightSlices {
            control: &mut *control,
            slices: 0,
            worst: 0,
        };
        if let Err(e) = window.run(pin!(measured.finish_stepwise())).await {
            defmt::println!("window n={=u32} not conditioned: {}", n, e);
            continue;
        }
        let outcome = read_window(
            &mut window,
            measured,
            kept.as_slice(),
            &record,
            &held,
            settings.seed,
            &mut fusion,
        )
        .await;
        slices = slices.saturating_add(window.slices);
        worst = worst.max(window.worst);
        let WindowRead {
            reading,
            conditions,
            fused,
        } = match outcome {
            Ok(r) => r,
            Err(e) => {
                defmt::println!("window n={=u32} cannot be read: {}", n, e);
                continue;
            }
        };
        read += 1;
        if fused {
            entered += 1;
            fitness_sum += reading.fit.error;
            first_day.get_or_insert(RecordedDay::of(&conditions));
        }
        defmt::println!(
            "window n={=u32} first_frame={=u32} frames={=u32} verdict={} outcome={} evaluations={=u32} slices={=u32} worst_slice_instructions={=u32} flying={=bool}",
            n,
            first_frame,
            frames,
            reading.verdict,
            WindowOutcome::of(&reading.verdict, &held, fused),
            reading.evaluations,
            window.slices,
            window.worst,
            control.flying()
        );
        print_window_bits(n, &reading);
    }
    let mut finish = FlightSlices {
        control: &mut *control,
        slices: 0,
        worst: 0,
    };
    let flight = finish
        .run(pin!(fusion.final_reading_stepwise(FLIGHT_MAX_FRICTION_STD)))
        .await;
    slices = slices.saturating_add(finish.slices);
    worst = worst.max(finish.worst);
    // The flight goes on until its demand goes.
    while control.flying() {
        control.serve();
        yield_now().await;
    }
    defmt::println!(
        "flight over: {} after {=u32} frames",
        control.state,
        control.frames
    );
    match flight {
        Ok(f) => {
            defmt::println!(
                "flight windows={=u32} entered={=u32} verdict={} faults={} worst_slice_instructions={=u32} slices={=u32}",
                read,
                entered,
                f.verdict,
                f.faults.as_array(),
                worst,
                slices
            );
            firmware::flight::print_flight_bits(&f);
            Some(Flown {
                reading: f,
                fitness_sum,
                entered,
                day: first_day.unwrap_or(RecordedDay::UNKNOWN),
                magnets: held.magnets(),
            })
        }
        Err(e) => {
            defmt::println!(
                "flight windows={=u32} entered={=u32} verdict=none reason={} worst_slice_instructions={=u32} slices={=u32}",
                read,
                entered,
                e,
                worst,
                slices
            );
            None
        }
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    bridge_off();
    let (file, line) = info.location().map_or(("?", 0), |l| (l.file(), l.line()));
    defmt::error!("panic at {=str}:{=u32}", file, line);
    loop {
        cortex_m::asm::wfi();
    }
}
