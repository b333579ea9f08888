//! What the day changes, as the FDI estimates it from one test: the winding's temperature
//! (hence its copper resistance and the magnets' flux) from the injection segment, averaged
//! with the thermistor where the test carries its reading, the gear's
//! friction from the measured temperature through the calibrated law — or, for a grease with
//! a drag of its own, from the chirp's drag (`crate::physics::grease`) through the law by drag, with
//! the drag above the calibration day's played on the model's motor shaft — and the
//! measured bus.
//!
//! Units: °C (K for differences), Ω, H, V. [`TestConditions::estimate`] is O(segment samples)
//! (one pass, two 2 × 2 least-squares fits per pair), allocates nothing and never panics; a
//! test without an injection segment, or whose segment carried too little current, keeps the
//! calibration's temperature ([`WindingEstimate`] says why).
//!
//! Why the injection tells temperature from a short: each pair answers the tone as
//! `i_{k+1} = a·i_k + b·v_k` with `a = exp(−R·dt/L)`, `b = (1 − a)/R` (the exact step response
//! the monitor model plays). A short of `N` healthy turns scales a phase's `L` by `N²` and its
//! `R` by `N`; temperature moves `R` alone (copper, 0.393 %/K). The three pairs' `L` give the
//! three `N`; what is left of each pair's `R` is the copper's temperature.

use crate::base::math::{exp, ln};
use crate::model::calibration::Calibration;
use crate::physics::grease::GreaseReading;
use crate::physics::params::{ActuatorParams, REFERENCE_TEMPERATURE};
use crate::test::conditioning::{LowPassState, MeasuredCurrent};
use crate::test::test_design::PAIR_SIGNS;

/// Copper's resistance coefficient [1/K].
pub const COPPER_COEFFICIENT: f32 = 0.00393;
/// Largest square of a phase's healthy turns the injection's inductances may show [-]: a
/// short takes turns away (N < 1), nothing adds them. Measured over the robustness grid
/// (docs/robustness.md): at most 1.049 on either example actuator, shorts included; the
/// reference actuator on a drive with 1 µs of dead time instead of 0.5 µs reads up to 1.15.
pub const MAX_TURNS_SQUARED: f32 = 1.10;

/// Largest disagreement between the injection's winding temperature and the thermistor's
/// \[K\] of an installation the calibration still describes. Measured over the robustness
/// grid (docs/robustness.md): at most 13.4 K on either example actuator, shorts included,
/// 3 seeds; a controller 25 µs later than its record reads −150 K (the fit's bound).
pub const MAX_WINDING_DISAGREEMENT: f32 = 20.0;
/// How far beyond the drags `calibrate --at` measured (the calibration day's and each
/// friction point's) the chirp's drag may read before the friction law by drag is no longer
/// trusted: a quarter, as a ratio. A base oil's viscosity moves that much over 2–5 K in the
/// cold and ≈ 10 K in the heat, and the fit's scatter is 0.3–3 % (docs/identifiability.md
/// §0c); beyond it the gearbox is colder or warmer than any point measured, or the grease is
/// not the calibrated one (aged, contaminated, another grade), and the healthy friction is
/// not known.
pub const DRAG_MARGIN: f32 = 1.25;
/// Half-width of the difference over which the friction law's slope is read \[K\]
/// ([`friction_slope`]): the gearbox's spread from the thermistor is of this order.
pub const SLOPE_HALF_WIDTH: f32 = 10.0;
/// Least RMS pair current \[A\] under which a pair's fit is not trusted (a segment that
/// carried nothing).
pub const MIN_PAIR_CURRENT: f32 = 0.05;
/// Samples skipped at the start of each pair's window: the conditioning filter's memory and
/// the switch from the previous pair.
const SKIP: usize = 10;

/// One pair's answer to the tone: resistance \[Ω\] and inductance \[H\] of the pair circuit, as
/// seen through the commanded volts.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PairImpedance {
    pub resistance: f32,
    pub inductance: f32,
    /// RMS of the pair's measured current over its window \[A\].
    pub rms_current: f32,
}

/// How the winding temperature was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WindingEstimate {
    /// From the injection's pair resistances.
    Injection,
    /// The test has no injection segment: the calibration's temperature is assumed.
    NoInjection,
    /// A pair carried less than [`MIN_PAIR_CURRENT`]: assumed.
    PairCarriedNothing { pair: u8 },
    /// A pair carried current but its fit is no R–L circuit (a resistance or inductance
    /// of zero or less), or (`pair` 3) the three pairs' inductances give a phase more turns
    /// than it has ([`MAX_TURNS_SQUARED`]): the bridge, harness or controller timing is not
    /// the calibrated one.
    PairNotPhysical { pair: u8 },
}

/// The day of one test, as the FDI uses it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TestConditions {
    /// Winding temperature minus the calibration's \[K\] (estimated: the injection's copper,
    /// averaged with the thermistor where the test carries one).
    pub winding_rise: f32,
    /// The injection's own estimate minus the thermistor's reading, both from the
    /// calibration's \[K\] (0 without either): beyond [`MAX_WINDING_DISAGREEMENT`] the pair
    /// circuits no longer answer as the calibration's did — another bridge, harness or
    /// controller timing — and the test is outside the domain.
    pub winding_disagreement: f32,
    /// Copper resistance against the calibration's [-].
    pub copper_scale: f32,
    /// The injection's installed pair resistance (copper, harness, switches) against the
    /// calibration's [-]: the copper's change, diluted by what does not heat.
    pub pair_resistance_ratio: f32,
    /// Magnet flux against the calibration's [-].
    pub flux_scale: f32,
    /// Healthy dry friction against the calibration's [-]: from the chirp's drag where the
    /// calibration has a friction law by drag (a grease with a drag of its own), else from
    /// the measured temperature.
    pub friction_scale: f32,
    /// How fast ln(healthy friction) moves with the gearbox's temperature at the measured
    /// one \[1/K\] ([`friction_slope`]); 0 without a measured temperature or a friction law.
    /// Times the record's declared spread of the gearbox from the thermistor, it is the
    /// day's healthy friction's deviation, which the preflight's friction deviation carries
    /// ([`crate::solver::uncertainty::SystematicError::on_day`]): a friction reading that the
    /// day's healthy friction can explain is not proven a fault.
    pub friction_slope: f32,
    /// The chirp's viscous drag above the calibration's, in its own units (equivalent
    /// current per radian of a block's motor travel; `crate::physics::grease`), where the calibration
    /// has a friction law by drag; 0 otherwise. The monitor model plays it as a drag on the
    /// motor shaft.
    pub drag_rise: f32,
    /// Where the calibration has a friction law by drag and the test cannot use it: the
    /// chirp's drag against the calibration's, beyond the drags the law was measured at by
    /// more than [`DRAG_MARGIN`], or NaN when the chirp gave no drag to read. `None`: the law
    /// applies, or there is none. The test is then outside the domain
    /// (`crate::model::domain::OutsideReason::GreaseOutOfRange`).
    pub drag_outside_law: Option<f32>,
    /// What the controller measured: mean temperature [°C] and bus \[V\].
    pub measured_temperature: Option<f32>,
    pub bus_voltage: Option<f32>,
    pub winding: WindingEstimate,
    /// Each pair's fit (zero where there is none).
    pub pairs: [PairImpedance; 3],
}

impl TestConditions {
    /// The calibration's own day: nothing corrected.
    pub const CALIBRATION: Self = Self {
        winding_rise: 0.0,
        winding_disagreement: 0.0,
        copper_scale: 1.0,
        pair_resistance_ratio: 1.0,
        flux_scale: 1.0,
        friction_scale: 1.0,
        friction_slope: 0.0,
        drag_rise: 0.0,
        drag_outside_law: None,
        measured_temperature: None,
        bus_voltage: None,
        winding: WindingEstimate::NoInjection,
        pairs: [PairImpedance {
            resistance: 0.0,
            inductance: 0.0,
            rms_current: 0.0,
        }; 3],
    };

    /// The day of the test in `measured` (finished or not), for an actuator of `params`
    /// calibrated by `calibration`. O(segment samples).
    pub fn estimate<const N: usize>(
        measured: &MeasuredCurrent<N>,
        params: &ActuatorParams,
        calibration: &Calibration,
    ) -> Self {
        Self::of_gearbox(measured)
            .with_thermistor_friction(calibration)
            .with_grease(measured.grease().ok(), calibration)
            .with_slope(calibration)
            .with_winding(measured, params, calibration)
    }

    /// [`estimate`](Self::estimate) in polls, for a controller's idle time: the gearbox's
    /// readings, the friction by the thermistor, the grease's fit and its word, the friction law's slope, the winding's day (the standstill pairs). The same
    /// day.
    pub async fn estimate_stepwise<const N: usize>(
        measured: &MeasuredCurrent<N>,
        params: &ActuatorParams,
        calibration: &Calibration,
    ) -> Self {
        use crate::base::steps::pause;
        let mut day = Self::of_gearbox(measured);
        pause().await;
        if let Some(t) = day.measured_temperature {
            day.friction_scale = friction_factor_stepwise(calibration, t).await;
        }
        pause().await;
        let grease = measured.grease_stepwise().await.ok();
        pause().await;
        let mut day = day.with_grease(grease, calibration);
        pause().await;
        if let Some(t) = day.measured_temperature {
            let above = friction_factor_stepwise(calibration, t + SLOPE_HALF_WIDTH).await;
            pause().await;
            let below = friction_factor_stepwise(calibration, t - SLOPE_HALF_WIDTH).await;
            pause().await;
            day.friction_slope = slope_between(above, below);
        }
        pause().await;
        day.with_winding(measured, params, calibration)
    }

    /// The gearbox's readings of the test: the thermistor's mean and the bus voltage; the
    /// rest at the calibration's.
    #[inline(never)]
    fn of_gearbox<const N: usize>(measured: &MeasuredCurrent<N>) -> Self {
        let sums = measured.conditions();
        Self {
            measured_temperature: sums.temperature(),
            bus_voltage: sums.bus_voltage(),
            ..Self::CALIBRATION
        }
    }

    /// This day with the friction's scale by the thermistor (its slope:
    /// [`with_slope`](Self::with_slope)).
    #[inline(never)]
    fn with_thermistor_friction(mut self, calibration: &Calibration) -> Self {
        self.friction_scale = self
            .measured_temperature
            .map_or(1.0, |t| friction_factor(calibration, t));
        self
    }

    /// This day with the grease's word on the friction, `grease` the test's fit
    /// (`MeasuredCurrent::grease`): a grease with a drag of its own has its drag for the
    /// gearbox's thermometer (solved only with a law to read it; the fit is accumulated
    /// either way).
    #[inline(never)]
    fn with_grease(mut self, grease: Option<GreaseReading>, calibration: &Calibration) -> Self {
        if calibration.viscous > 0.0 {
            let ratio = grease.map_or(f32::NAN, |g| g.viscous / calibration.viscous);
            match (grease, friction_factor_by_drag(calibration, ratio)) {
                (Some(grease), Some(factor)) => {
                    self.friction_scale = factor;
                    self.drag_rise = grease.viscous - calibration.viscous;
                    if !drag_within_law(calibration, ratio) {
                        self.drag_outside_law = Some(ratio);
                    }
                }
                // No drag to read (too few chirp blocks, a singular fit, no drag at all).
                _ => self.drag_outside_law = Some(ratio),
            }
        }
        self
    }

    /// This day with the friction law's slope at the thermistor's temperature.
    #[inline(never)]
    fn with_slope(mut self, calibration: &Calibration) -> Self {
        self.friction_slope = self
            .measured_temperature
            .map_or(0.0, |t| friction_slope(calibration, t));
        self
    }

    /// This day with the winding's part: the standstill pairs' impedances, the phases'
    /// healthy turns and the copper's temperature they give (with the thermistor's).
    #[inline(never)]
    fn with_winding<const N: usize>(
        self,
        measured: &MeasuredCurrent<N>,
        params: &ActuatorParams,
        calibration: &Calibration,
    ) -> Self {
        let mut out = self;
        let measured_temperature = out.measured_temperature;
        let (pairs, winding) = pair_impedances(
            measured,
            params.control_period,
            calibration.delay_share(params.control_period),
        );
        out.pairs = pairs;
        out.winding = winding;
        if winding != WindingEstimate::Injection {
            return out;
        }
        // The three pairs' L give the phases' healthy turns: q_p = N_y² + N_z².
        let l0 = params.phase_inductance * calibration.pair_inductance_scale;
        let q = pairs.map(|p| p.inductance / l0);
        let [q_ab, q_bc, q_ca] = q;
        let squares = [
            0.5 * (q_ab + q_ca - q_bc),
            0.5 * (q_ab + q_bc - q_ca),
            0.5 * (q_bc + q_ca - q_ab),
        ];
        // A fault only takes turns away: more inductance than the healthy winding has is
        // another bridge or harness than the calibrated one.
        if squares.iter().any(|&x| x > MAX_TURNS_SQUARED) {
            out.winding = WindingEstimate::PairNotPhysical { pair: 3 };
            return out;
        }
        let turns = squares.map(|x| crate::base::math::sqrt(x.clamp(0.01, 4.0)));
        // What is left of each pair's R is the copper's temperature.
        let r0 = params.phase_resistance * calibration.pair_resistance_scale;
        let mut ratio_sum = 0.0f32;
        for (j, signs) in PAIR_SIGNS.iter().enumerate() {
            let n: f32 = signs
                .iter()
                .zip(&turns)
                .filter(|(s, _)| **s != 0)
                .map(|(_, n)| *n)
                .sum();
            let r = pairs.get(j).map_or(0.0, |p| p.resistance);
            ratio_sum += r / (r0 * n.max(0.05));
        }
        let ratio = ratio_sum / 3.0;
        // The copper's share of the installed R at the calibration's temperature: the data
        // sheet's R moved to that temperature, against the fitted installed R.
        let copper_at_calibration =
            1.0 + COPPER_COEFFICIENT * (calibration.temperature - REFERENCE_TEMPERATURE);
        let share = (copper_at_calibration / calibration.pair_resistance_scale).clamp(0.05, 1.0);
        let rise = (ratio - 1.0) / (share * COPPER_COEFFICIENT / copper_at_calibration);
        let from_injection = rise.clamp(-150.0, 200.0);
        // With a thermistor reading, the mean of the two: the injection's estimate scatters
        // by a few kelvin from test to test, the thermistor has its bias (both measured:
        // docs/robustness.md).
        let rise = match measured_temperature {
            Some(t) => {
                out.winding_disagreement = from_injection - (t - calibration.temperature);
                0.5 * (from_injection + (t - calibration.temperature))
            }
            None => from_injection,
        };
        out.winding_rise = rise;
        out.copper_scale = 1.0 + COPPER_COEFFICIENT * rise / copper_at_calibration;
        out.pair_resistance_ratio = 1.0 + share * COPPER_COEFFICIENT * rise / copper_at_calibration;
        out.flux_scale = 1.0 + calibration.magnet_coefficient * rise;
        out
    }
}

/// The healthy dry friction at measured temperature `celsius` against the calibration's:
/// `ln(factor)` linear in temperature between the calibration's points (its own at factor 1
/// and [`Calibration::friction_points`], which the record keeps in rising temperature, unused
/// ones last), held beyond the outermost. O(points), no allocation.
#[inline(never)]
pub fn friction_factor(calibration: &Calibration, celsius: f32) -> f32 {
    log_law(
        calibration.temperature,
        &calibration.friction_points,
        celsius,
    )
}

/// How fast ln(healthy friction) moves with temperature at `celsius` \[1/K\]
/// ([`TestConditions::friction_slope`]): the law's change of ln(friction) between `celsius` ±
/// [`SLOPE_HALF_WIDTH`], over the width; 0 without a law. O(points).
pub fn friction_slope(calibration: &Calibration, celsius: f32) -> f32 {
    slope_between(
        friction_factor(calibration, celsius + SLOPE_HALF_WIDTH),
        friction_factor(calibration, celsius - SLOPE_HALF_WIDTH),
    )
}

/// [`friction_factor`] in steps, for a controller's idle time: the law's point, then its
/// exponential stepwise ([`crate::base::math::exp64_stepwise`]). The same bits.
async fn friction_factor_stepwise(calibration: &Calibration, celsius: f32) -> f32 {
    let at = log_law_value(
        calibration.temperature,
        &calibration.friction_points,
        celsius,
    );
    crate::base::steps::pause().await;
    at.value_stepwise().await
}

/// The slope between the friction factors `above` and `below` [`SLOPE_HALF_WIDTH`] either
/// side ([`friction_slope`]).
fn slope_between(above: f32, below: f32) -> f32 {
    crate::base::math::abs(ln(above) - ln(below)) / (2.0 * SLOPE_HALF_WIDTH)
}

/// The healthy dry friction at the chirp's viscous drag `ratio` (against the calibration's)
/// against the calibration's: `ln(factor)` linear in `ln(ratio)` between the calibration's
/// points (its own at (1, 1) and each friction point's drag and factor; the record keeps the
/// drags falling as the temperatures rise), held beyond the outermost. `None` where the
/// calibration has no friction law by drag ([`Calibration::viscous`] 0) or `ratio` is no
/// drag. O(points), no allocation.
#[inline(never)]
pub fn friction_factor_by_drag(calibration: &Calibration, ratio: f32) -> Option<f32> {
    if !(calibration.viscous > 0.0 && ratio > 0.0 && ratio.is_finite()) {
        return None;
    }
    // The points by rising drag: the record's order reversed, at ln(drag).
    let mut points = [[0.0f32; 2]; 4];
    for (slot, (factor, drag)) in points.iter_mut().zip(law_points(calibration).rev()) {
        *slot = [ln(drag), factor];
    }
    Some(log_law(0.0, &points, ln(ratio)))
}

/// Whether the chirp's drag `ratio` (against the calibration's) lies within the drags the
/// friction law by drag was measured at — the calibration day's (1) and each used friction
/// point's — widened by [`DRAG_MARGIN`] at both ends. O(points).
pub fn drag_within_law(calibration: &Calibration, ratio: f32) -> bool {
    let (low, high) =
        law_points(calibration).fold((1.0f32, 1.0f32), |(lo, hi), (_, d)| (lo.min(d), hi.max(d)));
    ratio >= low / DRAG_MARGIN && ratio <= high * DRAG_MARGIN
}

/// The friction law by drag's measured points, `(factor, drag)` in the record's order
/// (rising temperature, falling drag): the friction points in use with a drag. O(points).
fn law_points(calibration: &Calibration) -> impl DoubleEndedIterator<Item = (f32, f32)> + '_ {
    calibration
        .friction_points
        .iter()
        .zip(&calibration.drag_points)
        .filter(|([_, factor], drag)| *factor > 0.0 && **drag > 0.0)
        .map(|([_, factor], drag)| (*factor, *drag))
}

/// `ln(factor)` linear in `x` between `points` (`[x, factor]` in rising `x`, unused ones —
/// factor 0 — last) and the calibration's own `(own, 1)` in its place among them, held beyond
/// the outermost. O(points), no allocation.
fn log_law(own: f32, points: &[[f32; 2]; 4], x: f32) -> f32 {
    log_law_value(own, points, x).value()
}

/// A law's value at a point: given by a point of the law, or the log to exponentiate.
#[derive(Clone, Copy)]
enum LawValue {
    Exact(f32),
    Log(f32),
}

impl LawValue {
    fn value(self) -> f32 {
        match self {
            Self::Exact(v) => v,
            Self::Log(l) => exp(l),
        }
    }

    /// [`value`](Self::value) with its exponential stepwise: the same bits.
    async fn value_stepwise(self) -> f32 {
        match self {
            Self::Exact(v) => v,
            Self::Log(l) => crate::base::math::exp64_stepwise(f64::from(l)).await as f32,
        }
    }
}

/// [`log_law`] up to its exponential.
fn log_law_value(own: f32, points: &[[f32; 2]; 4], x: f32) -> LawValue {
    let own = [own, 1.0];
    let mut previous: Option<(f32, f32)> = None;
    let mut own_placed = false;
    let mut next = points.iter().filter(|p| p[1] > 0.0).copied().peekable();
    loop {
        let point = match next.peek() {
            Some(p) if own_placed || p[0] < own[0] => next.next(),
            _ if !own_placed => {
                own_placed = true;
                Some(own)
            }
            _ => None,
        };
        let Some([t, factor]) = point else {
            break;
        };
        let log = ln(factor);
        match previous {
            None if x <= t => return LawValue::Exact(factor),
            Some((t0, l0)) if x <= t => {
                return LawValue::Log(l0 + (log - l0) * (x - t0) / (t - t0).max(1e-3));
            }
            _ => previous = Some((t, log)),
        }
    }
    previous.map_or(LawValue::Exact(1.0), |(_, log)| LawValue::Log(log))
}

/// Each pair's R and L from the injection segment of `measured` (control period `dt`): the
/// regression `y_{k+1} = a·y_k + b·u_k` of the filtered measured pair current `y` on the
/// volts `u` the pair saw over each period through the same filter, over the pair's window
/// past `SKIP` samples. A controller whose volts take effect `delay` of a period after
/// their sample applies the previous period's for that share of each period: `u` is the
/// commanded volts blended with the previous period's by `delay` (an R–L circuit whose time
/// constant is many periods sees the period's mean). O(segment samples), no allocation.
#[inline(never)]
pub fn pair_impedances<const N: usize>(
    measured: &MeasuredCurrent<N>,
    dt: f32,
    delay: f32,
) -> ([PairImpedance; 3], WindingEstimate) {
    let mut out = [PairImpedance::default(); 3];
    // Normal equations per pair: [Σyy Σyu; Σyu Σuu]·[a b] = [Σy'y Σy'u], and Σy², n.
    let mut sums = [[0.0f32; 7]; 3];
    let found = injection_rows(measured, dt, delay, |pair, [y0, u0, y]| {
        if let Some(s) = sums.get_mut(pair) {
            s[0] += y0 * y0;
            s[1] += y0 * u0;
            s[2] += u0 * u0;
            s[3] += y * y0;
            s[4] += y * u0;
            s[5] += y * y;
            s[6] += 1.0;
        }
    });
    if !found {
        return (out, WindingEstimate::NoInjection);
    }
    for (j, (s, slot)) in sums.iter().zip(out.iter_mut()).enumerate() {
        let det = s[0] * s[2] - s[1] * s[1];
        let mean_square = if s[6] > 0.0 { s[5] / s[6] } else { 0.0 };
        if mean_square < MIN_PAIR_CURRENT * MIN_PAIR_CURRENT
            || det.abs() <= f32::EPSILON * s[0] * s[2]
        {
            return (out, WindingEstimate::PairCarriedNothing { pair: j as u8 });
        }
        let a = (s[3] * s[2] - s[4] * s[1]) / det;
        let b = (s[0] * s[4] - s[1] * s[3]) / det;
        if !(a > 0.0 && a < 1.0 && b > 0.0) {
            return (out, WindingEstimate::PairNotPhysical { pair: j as u8 });
        }
        let resistance = (1.0 - a) / b;
        *slot = PairImpedance {
            resistance,
            inductance: -resistance * dt / ln(a),
            rms_current: crate::base::math::sqrt(mean_square),
        };
    }
    (out, WindingEstimate::Injection)
}

/// Hands `row` each fitted row of the injection's regression, in order: the pair (0 = A→B),
/// and `[y_k, u_k, y_{k+1}]`, the filtered measured pair current and the filtered volts the
/// pair saw over period k (control period `dt`): from a controller whose volts take effect
/// `delay` of a period (0 … 1) after their sample, the previous period's volts for that
/// share and this period's for the rest (0 V before the segment). `false` when the test has no injection
/// segment. O(segment samples), no allocation.
#[inline(always)]
pub fn injection_rows<const N: usize>(
    measured: &MeasuredCurrent<N>,
    dt: f32,
    delay: f32,
    mut row: impl FnMut(usize, [f32; 3]),
) -> bool {
    let Some(segment) = measured.test().standstill.filter(|s| s.is_injection()) else {
        return false;
    };
    let samples = measured.samples();
    let filter = measured.filter();
    let mut state = LowPassState::default();
    let settle = usize::from(segment.settle_samples);
    let per_pair = usize::from(segment.on_samples) + usize::from(segment.off_samples);
    let mut previous: Option<(f32, f32)> = None;
    // The previous period's volts, which hold for `delay` of each period.
    let mut commanded = 0.0f32;
    for index in 0..segment.samples().min(samples.len()) {
        let Some(drive) = segment.at(index) else {
            break;
        };
        let volts = drive.voltage(dt);
        let u = filter.apply(&mut state, volts + delay * (commanded - volts));
        commanded = volts;
        let y = samples.get(index).copied().unwrap_or(0.0);
        let within = index.checked_sub(settle).map(|i| i % per_pair);
        if let (Some(w), Some((y0, u0))) = (within, previous) {
            if w > SKIP {
                row(drive.pair, [y0, u0, y]);
            }
        }
        previous = Some((y, u));
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_friction_law_by_drag_reads_the_grease_and_needs_a_drag_that_moves() {
        let mut c = Calibration::IDENTITY;
        c.friction_points = [[-45.0, 3.0], [-25.0, 2.0], [0.0, 1.3], [75.0, 0.5]];
        c.drag_points = [7.0, 3.5, 1.8, 0.5];
        // No drag measured: no law.
        assert_eq!(friction_factor_by_drag(&c, 3.5), None);
        c.viscous = 0.01;
        let at = |r: f32| friction_factor_by_drag(&c, r).unwrap();
        // At each point its own factor, at the calibration's drag 1; held beyond the ends.
        for (drag, factor) in [(7.0, 3.0), (3.5, 2.0), (1.8, 1.3), (1.0, 1.0), (0.5, 0.5)] {
            assert!((at(drag) - factor).abs() < 1e-4, "{drag}: {}", at(drag));
        }
        assert!((at(20.0) - 3.0).abs() < 1e-4);
        assert!((at(0.1) - 0.5).abs() < 1e-4);
        // Between two points, ln(factor) linear in ln(drag): the geometric mean halfway.
        let mid = (3.5f32 * 7.0).sqrt();
        assert!((at(mid) - 6.0f32.sqrt()).abs() < 1e-3, "{}", at(mid));
        // No drag, or not a number: no reading.
        assert_eq!(friction_factor_by_drag(&c, 0.0), None);
        assert_eq!(friction_factor_by_drag(&c, f32::NAN), None);
        // Without the calibration's drag (a grease whose drag does not move: `calibrate`
        // writes none), no law.
        c.viscous = 0.0;
        assert_eq!(friction_factor_by_drag(&c, 3.5), None);
    }

    #[test]
    fn the_law_by_drag_holds_a_quarter_beyond_its_measured_drags_and_no_further() {
        let mut c = Calibration::IDENTITY;
        c.viscous = 0.01;
        c.friction_points = [[-45.0, 3.0], [-25.0, 2.0], [0.0, 1.3], [75.0, 0.5]];
        c.drag_points = [7.0, 3.5, 1.8, 0.5];
        for (ratio, within) in [
            (1.0, true),
            (7.0, true),
            (7.0 * 1.24, true),
            (7.0 * 1.26, false),
            (0.5 / 1.24, true),
            (0.5 / 1.26, false),
            (f32::NAN, false),
        ] {
            assert_eq!(drag_within_law(&c, ratio), within, "{ratio}");
        }
        // Unused points (factor 0) do not widen it; the calibration day's own drag (1) is
        // always in it.
        c.friction_points = [[-45.0, 3.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]];
        c.drag_points = [7.0, 0.1, 0.1, 0.1];
        assert!(!drag_within_law(&c, 0.5));
        assert!(drag_within_law(&c, 0.81));
    }

    #[test]
    fn the_friction_law_interpolates_its_logarithm_and_holds_at_the_ends() {
        let mut c = Calibration::IDENTITY;
        assert_eq!(friction_factor(&c, -40.0), 1.0);
        c.friction_points = [[-40.0, 3.0], [80.0, 0.75], [0.0, 0.0], [0.0, 0.0]];
        assert!((friction_factor(&c, 50.0) - 0.75f32.sqrt()).abs() < 1e-4);
        assert!((friction_factor(&c, -40.0) - 3.0).abs() < 1e-5);
        assert!((friction_factor(&c, -60.0) - 3.0).abs() < 1e-5);
        assert!((friction_factor(&c, 20.0) - 1.0).abs() < 1e-6);
        // Halfway between 20 °C (1) and −40 °C (3) in temperature: √3 in factor.
        assert!((friction_factor(&c, -10.0) - 3.0f32.sqrt()).abs() < 1e-4);
        assert!((friction_factor(&c, 100.0) - 0.75).abs() < 1e-5);
    }

    #[test]
    fn the_healthy_frictions_slope_is_the_laws() {
        let mut c = Calibration::IDENTITY;
        // No law: friction does not move with temperature, the day adds nothing.
        assert_eq!(friction_slope(&c, -40.0), 0.0);
        c.friction_points = [[-40.0, 3.0], [80.0, 0.75], [0.0, 0.0], [0.0, 0.0]];
        // Between −40 and 20 °C ln(friction) falls ln 3 over 60 K.
        let cold = friction_slope(&c, -10.0);
        let want = 3.0f32.ln() / 60.0;
        assert!((cold - want).abs() < 1e-5, "{cold} {want}");
        // Between 20 and 80 °C it falls ln(4/3) over 60 K: a smaller slope in the heat.
        let hot = friction_slope(&c, 50.0);
        assert!((hot - (4.0f32 / 3.0).ln() / 60.0).abs() < 1e-5);
        assert!(hot < cold);
        // Beyond the outermost point the law holds: only the side inside it moves.
        assert!(friction_slope(&c, -45.0) < want);
    }
}
