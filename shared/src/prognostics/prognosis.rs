//! Degradation trends and remaining useful life (RUL), per fault, from the health log.
//!
//! Units: time in flights (one preflight per flight; an in-flight entry, a flight's reading
//! from its windows identified in flight, counts at its flight, after the preflight; a
//! window's own entry is not trended: its information is in its flight's reading), fault level in the fault vector's
//! normalised deviation from nominal ([`crate::physics::fault::FaultVector::deviations`]), RUL in flights.
//!
//! Trended quantities ([`TREND_COUNT`]): the fault vector's components but the eccentricity
//! phase, and the weak magnet's depth ([`WEAK_MAGNET_TREND`]: the share of one magnet's flux
//! lost, 0 where a preflight read none, wherever the magnet sits; a flight's reading holds its
//! preflight's magnet and adds nothing to it).
//!
//! ## Model
//!
//! Each fault's level is `y(t) = a + b·g(t − t₀) + ε`, `t₀` the first flight seen, for each
//! growth shape `g` of [`GROWTH_MODELS`] (three families):
//!
//! * linear, `g(Δ) = Δ`;
//! * exponential at rate `r` per flight, `g(Δ) = (e^{rΔ} − 1)/r` (MATLAB's
//!   `exponentialDegradationModel` with an offset), 11 rates from 0.01 to 0.3;
//! * power law of exponent `p`, `g(Δ) = Δ·(Δ/32)^{p−1}`, `p` ∈ {1.5, 2, 2.5, 3, 4}.
//!
//! Each observation `y_i` carries its own variance `v_i = max(σ_i, noise_floor)²`, `σ_i` the
//! identification's standard deviation of that component from the health record
//! ([`crate::solver::uncertainty`]; `noise_floor` where the record has none, as a version-1 record);
//! an in-flight entry's `σ_i` counts [`TrendSettings::flight_scale`] times (its errors against
//! what it states, over a preflight's).
//! For each shape a weighted recursive least-squares filter (the Bayesian linear update with a
//! flat prior) refines `(a, b)` and its covariance once per observation, O(1). The filter also
//! sums the squared standardised prediction errors (`χ²`), from which the scale
//! `ŝ² = χ²/(n − 2)` says how much more (or less) the levels scatter than their stated
//! variances: the stated deviations weigh the flights against each other, the history sets
//! their size (not below `noise_floor` for the typical flight).
//!
//! * **Shape weights.** Each family has a third of the prior, shared evenly by its members;
//!   the posterior weight of a shape is its prior times `exp(−χ²/(2ŝ²))` (`ŝ²` of the best
//!   shape): the shapes the history explains equally well share the weight.
//! * **Outliers.** From the fourth observation on, an observation whose standardised
//!   prediction error `z` exceeds [`TrendSettings::outlier_z`] = c has its variance inflated
//!   until `z = c`, so its pull is bounded whatever its size (counted in
//!   [`TrendEstimate::outliers`]).
//!
//! ## RUL
//!
//! The true level at a future flight `t` under shape `m` is taken as normal, with mean the
//! shape's fit and variance `ŝ²·φᵀPφ` (the fit's own uncertainty, widened to Student's t)
//! plus `systematic²` ([`TrendSettings::systematic`]: the identification's error that does not
//! average out over flights, seen in the campaigns). The probability that the level has
//! reached the threshold by `t`, mixed over the shapes by their weights, is the distribution
//! of the end of life; the RUL is its median, the 90 % interval its 5 % and 95 % points,
//! counted in flights from the newest. The points are searched on a grid of
//! `⌈horizon/64⌉`-flight steps and refined by bisection: `None` means beyond
//! [`TrendSettings::horizon`], `0` means reached already.
//!
//! Work bounds: [`FaultTrend::update`] O([`MODEL_COUNT`]); [`FaultTrend::estimate`]
//! O(`MODEL_COUNT · (64 + 3·24)`) evaluations of one shape's level and normal tail. State:
//! 976 bytes per fault. All in f64 from IEEE operations ([`crate::base::math::exp64`],
//! [`crate::base::math::sqrt64`]): the same bits on the host and on the controller.

use crate::base::math::{exp64, sqrt64};
use crate::physics::fault::{CIRCULAR, FAULT_COUNT, FAULT_NAMES};
use crate::prognostics::health::HealthRecord;
use crate::solver::weak_magnet::DEPTH_RESOLUTION;

/// Quantities trended: the fault vector's [`FAULT_COUNT`] components (the eccentricity
/// phase's trend stays empty) and the weak magnet's depth.
pub const TREND_COUNT: usize = FAULT_COUNT + 1;

/// The trended quantity that is the weak magnet's depth
/// ([`crate::physics::magnets::WeakMagnet::depth`]; 0 where a preflight read no weak magnet).
pub const WEAK_MAGNET_TREND: usize = FAULT_COUNT;

/// Names of the trended quantities: [`FAULT_NAMES`], then `weak_magnet`.
// Indexing in a constant is checked when it is built: no panic at run time.
#[allow(clippy::indexing_slicing)]
pub const TREND_NAMES: [&str; TREND_COUNT] = {
    let mut names = ["weak_magnet"; TREND_COUNT];
    let mut i = 0;
    while i < FAULT_COUNT {
        names[i] = FAULT_NAMES[i];
        i += 1;
    }
    names
};

/// A growth shape of the trend.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Growth {
    Linear,
    /// `(e^{rΔ} − 1)/r`, rate `r` per flight.
    Exponential(f32),
    /// `Δ·(Δ/32)^{p−1}`, exponent `p`.
    PowerLaw(f32),
}

/// Number of growth shapes tried.
pub const MODEL_COUNT: usize = 17;

/// Flights that scale the power-law shapes (their slope at `Δ = 32` is `p`).
const POWER_SCALE: f64 = 32.0;

/// The growth shapes tried: linear, 11 exponential rates (geometric from 0.01 to 0.3 per
/// flight), 5 power-law exponents.
pub const GROWTH_MODELS: [Growth; MODEL_COUNT] = [
    Growth::Linear,
    Growth::Exponential(0.01),
    Growth::Exponential(0.0136),
    Growth::Exponential(0.0186),
    Growth::Exponential(0.0254),
    Growth::Exponential(0.0346),
    Growth::Exponential(0.0472),
    Growth::Exponential(0.0644),
    Growth::Exponential(0.0879),
    Growth::Exponential(0.1199),
    Growth::Exponential(0.1636),
    Growth::Exponential(0.3),
    Growth::PowerLaw(1.5),
    Growth::PowerLaw(2.0),
    Growth::PowerLaw(2.5),
    Growth::PowerLaw(3.0),
    Growth::PowerLaw(4.0),
];

impl Growth {
    /// `g(Δ)`: this shape after `delta` flights.
    pub fn shape(self, delta: f64) -> f64 {
        match self {
            Self::Linear => delta,
            Self::Exponential(r) => {
                let r = f64::from(r);
                (exp64(r * delta) - 1.0) / r
            }
            Self::PowerLaw(p) => {
                let u = delta / POWER_SCALE;
                let u = if u > 0.0 { u } else { 0.0 };
                // Exponents are halves: u^(p−1) from whole powers and one square root.
                let twice = (2.0 * f64::from(p) - 2.0) as u32;
                let mut f = 1.0;
                for _ in 0..twice / 2 {
                    f *= u;
                }
                if twice % 2 == 1 {
                    f *= sqrt64(u);
                }
                delta * f
            }
        }
    }

    /// `dg/dΔ` at `delta`.
    fn slope(self, delta: f64) -> f64 {
        match self {
            Self::Linear => 1.0,
            Self::Exponential(r) => exp64(f64::from(r) * delta),
            Self::PowerLaw(p) => {
                if delta > 0.0 {
                    f64::from(p) * self.shape(delta) / delta
                } else {
                    0.0
                }
            }
        }
    }

    /// Prior weight: a third per family, shared evenly by its members.
    fn prior(self) -> f64 {
        match self {
            Self::Linear => 1.0 / 3.0,
            Self::Exponential(_) => 1.0 / 33.0,
            Self::PowerLaw(_) => 1.0 / 15.0,
        }
    }
}

/// Prior variance of `(a, b)` [level²]: flat.
const PRIOR_VARIANCE: f64 = 1.0e6;

/// Observations before outliers are judged (the scale needs some).
const OUTLIER_AFTER: u32 = 4;

/// Bisection steps that refine a quantile inside its grid step.
const BISECTION_STEPS: u32 = 24;

/// Grid steps over the horizon on which the quantiles are first bracketed.
const GRID_STEPS: u32 = 64;

/// Shapes lighter than this share of the total weight are left out of the mixture.
const NEGLIGIBLE_WEIGHT: f64 = 1.0e-6;

/// How trends are judged and RUL computed.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrendSettings {
    /// Maintenance threshold on each trended quantity ([`TREND_NAMES`]): each component's
    /// deviation from nominal, then the weak magnet's depth; NaN or ≤ 0: no RUL for it (the
    /// eccentricity phase is never trended).
    pub thresholds: [f32; TREND_COUNT],
    /// Least standard deviation of one observation, and the one assumed where the record
    /// carries none (version 1).
    pub noise_floor: f64,
    /// An in-flight entry's (a flight's reading, [`crate::prognostics::health::FLIGHT_READING`]) own
    /// noise: its stated standard deviation counts this many times, so that its weight
    /// against a preflight's follows their errors, not what each identification states (the
    /// windows' curvatures do not see their unknown load and turbulence as the preflight's
    /// sees its quiet test).
    pub flight_scale: f64,
    /// Standard deviation of the identification's error that does not average out over
    /// flights (model mismatch, correlated with the level), added to every prediction.
    pub systematic: f64,
    /// Standardised prediction error beyond which an observation is down-weighted.
    pub outlier_z: f64,
    /// Flights searched for a crossing.
    pub horizon: u32,
}

impl TrendSettings {
    /// Illustrative maintenance thresholds (the actuator maker sets its own): friction 0.5,
    /// backlash 0.5, each short 0.3, eccentricity 0.5, gain drift ±0.25, demagnetization 0.3
    /// (15 % of the flux lost: the torque constant's share of a typical 20 % torque margin),
    /// one weak magnet 0.5 (half of its flux lost).
    pub const DEFAULT: Self = Self {
        thresholds: [0.5, 0.5, 0.3, 0.3, 0.3, 0.5, f32::NAN, 0.25, 0.3, 0.5],
        // The random part of one test's error. Chosen with `systematic` on the prognostics
        // evaluation's seeds 0–2 (0.004–0.008 against 0.01–0.02: interval coverage 85–95 %)
        // and checked on seeds 3–5 (docs/prognostics.md).
        noise_floor: 0.005,
        // A flight's reading against what it states, over a preflight's: 4.23 for friction,
        // the most optimistic component (gain drift 2.52), on the evaluation's seed 0 with
        // eight windows per flight fused into its reading, the windows' shorts, eccentricity
        // and demagnetization held at the preflight's and the intervals' factors set with
        // Table I (259 readings `within`), rounded up to a half; 4.28 (the gain drift's, 388
        // readings) before those factors. Before the eccentricity was held it was the
        // eccentricity's 5.63 → 6; 3.94 → 4 with four windows and the shorts held, 4.57 → 5
        // before, and one window's own entry per flight gave 4.61 → 5 before flights'
        // readings (docs/prognostics.md, "In-flight entries").
        flight_scale: 4.5,
        // Mean errors of 0.011–0.018 on the Table II and random multi-fault vectors
        // (docs/accuracy.md): the level-correlated part of a test's error, which a history
        // does not average out.
        systematic: 0.015,
        outlier_z: 3.0,
        horizon: 500,
    };

    /// The threshold of component `i`, if it has one.
    pub fn threshold(&self, i: usize) -> Option<f32> {
        match self.thresholds.get(i) {
            Some(&t) if is_trended(i) && t > 0.0 => Some(t),
            _ => None,
        }
    }
}

/// Whether quantity `i` ([`TREND_NAMES`]) has a trend: every fault component but the
/// eccentricity phase, which is a location, and the weak magnet's depth.
pub fn is_trended(i: usize) -> bool {
    i == WEAK_MAGNET_TREND || !CIRCULAR.get(i).copied().unwrap_or(true)
}

/// The weak magnet's depth's standard deviation in the trend where a preflight read none: the
/// search reads depths in steps of [`DEPTH_RESOLUTION`] from its first grid depth, so a
/// magnet shallower than about two steps may read as none. A deviation of one step keeps
/// such a reading from pinning the trend at 0 while a small magnet grows unread.
pub const NO_MAGNET_STD: f32 = DEPTH_RESOLUTION;

/// Quantity `i` of `record` as its trend takes it ([`TREND_NAMES`]): a component's deviation
/// from nominal, or the weak magnet's depth (0 where none was read); `None` for the
/// eccentricity phase and past the last. O(1).
pub fn trended_value(record: &HealthRecord, i: usize) -> Option<f32> {
    if i == WEAK_MAGNET_TREND {
        Some(record.magnet.magnets().depth)
    } else {
        record.faults.deviations().get(i).copied().flatten()
    }
}

/// One shape's weighted recursive least-squares state.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ShapeFit {
    /// `(a, b)`.
    theta: [f64; 2],
    /// Covariance [level²]: `[p_aa, p_ab, p_bb]`.
    p: [f64; 3],
    /// Sum of squared standardised prediction errors (`χ²`).
    chi2: f64,
    outliers: u32,
}

impl ShapeFit {
    const PRIOR: Self = Self {
        theta: [0.0, 0.0],
        p: [PRIOR_VARIANCE, 0.0, PRIOR_VARIANCE],
        chi2: 0.0,
        outliers: 0,
    };

    fn mean(&self, g: f64) -> f64 {
        self.theta[0] + self.theta[1] * g
    }

    /// `φᵀPφ` for `φ = (1, g)`.
    fn spread(&self, g: f64) -> f64 {
        self.p[0] + 2.0 * self.p[1] * g + self.p[2] * g * g
    }

    /// `ŝ²`: observed scatter over stated, at least `floor`.
    fn scale(&self, n: u32, floor: f64) -> f64 {
        let dof = n.saturating_sub(2).max(1) as f64;
        let v = self.chi2 / dof;
        if v > floor {
            v
        } else {
            floor
        }
    }

    fn update(
        &mut self,
        g: f64,
        y: f64,
        v: f64,
        n_before: u32,
        floor: f64,
        settings: &TrendSettings,
    ) {
        let s = self.spread(g);
        let e = y - self.mean(g);
        let mut v = v;
        if n_before >= OUTLIER_AFTER {
            let limit =
                settings.outlier_z * settings.outlier_z * self.scale(n_before, floor) * (v + s);
            if e * e > limit {
                // Inflate the variance until the error is c standard deviations.
                v = (v + s) * (e * e / limit) - s;
                self.outliers += 1;
            }
        }
        // Gain K = Pφ / (v + φᵀPφ); P ← P − K φᵀP.
        let pg0 = self.p[0] + self.p[1] * g;
        let pg1 = self.p[1] + self.p[2] * g;
        let denom = v + s;
        let k0 = pg0 / denom;
        let k1 = pg1 / denom;
        self.theta[0] += k0 * e;
        self.theta[1] += k1 * e;
        self.p = [
            self.p[0] - k0 * pg0,
            self.p[1] - k0 * pg1,
            self.p[2] - k1 * pg1,
        ];
        self.chi2 += e * e / denom;
    }
}

/// Student's t 95 % quantile (two-sided 90 %) for `dof` degrees of freedom.
fn t90(dof: u32) -> f64 {
    const TABLE: [f64; 10] = [
        6.314, 2.920, 2.353, 2.132, 2.015, 1.943, 1.895, 1.860, 1.833, 1.812,
    ];
    match dof {
        0 => f64::INFINITY,
        1..=10 => TABLE.get(dof as usize - 1).copied().unwrap_or(1.812),
        11..=12 => 1.782,
        13..=15 => 1.753,
        16..=20 => 1.725,
        21..=30 => 1.697,
        31..=60 => 1.671,
        _ => 1.645,
    }
}

/// The normal distribution's two-sided 90 % quantile.
const Z90: f64 = 1.644_853_626_951_472_2;

/// `P(Z ≤ x)` for a standard normal `Z` (complementary error function of Numerical Recipes'
/// `erfcc`, relative error < 1.2·10⁻⁷).
fn normal_cdf(x: f64) -> f64 {
    let z = if x < 0.0 { -x } else { x } * core::f64::consts::FRAC_1_SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * exp64(poly);
    if x < 0.0 {
        0.5 * erfc
    } else {
        1.0 - 0.5 * erfc
    }
}

/// What every prediction of one estimate shares ([`FaultTrend::forecast`]).
struct Forecast {
    weights: [f64; MODEL_COUNT],
    scale: [f64; MODEL_COUNT],
    grows: [bool; MODEL_COUNT],
    widen: f64,
}

/// One fault's trend: every shape's filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultTrend {
    origin: u32,
    newest: u32,
    observations: u32,
    /// Sum of the observations' inverse variances (their typical variance for reports).
    precision: f64,
    fits: [ShapeFit; MODEL_COUNT],
}

impl Default for FaultTrend {
    fn default() -> Self {
        Self::new()
    }
}

/// RUL in flights from the newest observation: `None` beyond the horizon, `Some(0.0)`
/// reached already.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RulEstimate {
    /// Median of the end-of-life distribution.
    pub rul: Option<f32>,
    /// 90 % interval: its 5 % point...
    pub lower: Option<f32>,
    /// ...and its 95 % point.
    pub upper: Option<f32>,
}

/// The trend of one fault after the newest observation.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrendEstimate {
    pub observations: u32,
    /// Observations down-weighted as outliers (by the likeliest shape's filter).
    pub outliers: u32,
    /// Newest flight seen.
    pub newest: u32,
    /// The likeliest growth shape...
    pub growth: Growth,
    /// ...and its posterior weight (0..1).
    pub weight: f32,
    /// Fitted level at the newest flight (likeliest shape).
    pub level: f32,
    /// Fitted growth per flight at the newest flight (likeliest shape).
    pub slope: f32,
    /// Standard deviation of one observation as the history shows it: the typical stated
    /// one times `ŝ`.
    pub scatter: f32,
    /// Set when the component has a threshold.
    pub rul: Option<RulEstimate>,
}

impl FaultTrend {
    pub const fn new() -> Self {
        Self {
            origin: 0,
            newest: 0,
            observations: 0,
            precision: 0.0,
            fits: [ShapeFit::PRIOR; MODEL_COUNT],
        }
    }

    pub fn observations(&self) -> u32 {
        self.observations
    }

    /// Adds the level `value` observed at `flight`'s preflight (`in_flight` false) or in
    /// flight (an in-flight entry, taken at its flight: the wear of one flight is nil), with
    /// the identification's standard deviation `std` (not below
    /// [`TrendSettings::noise_floor`]; `None`: not known, the floor — an in-flight entry
    /// without one is ignored, not read in flight; an in-flight entry's counts
    /// [`TrendSettings::flight_scale`] times). Flights must not go
    /// back, and a preflight must be newer than every observation: an older flight, a
    /// repeated preflight or a non-finite value is ignored (returns false). O(MODEL_COUNT).
    pub fn update(
        &mut self,
        flight: u32,
        in_flight: bool,
        value: f32,
        std: Option<f32>,
        settings: &TrendSettings,
    ) -> bool {
        // An in-flight component with no deviation was not read in flight (held at its
        // preflight's, or undetermined): the preflight already counts it.
        if !value.is_finite()
            || (in_flight && std.is_none())
            || (self.observations > 0
                && (flight < self.newest || (flight == self.newest && !in_flight)))
        {
            return false;
        }
        if self.observations == 0 {
            self.origin = flight;
        }
        let sd = match std {
            Some(s) if f64::from(s) > settings.noise_floor => f64::from(s),
            _ => settings.noise_floor,
        } * if in_flight {
            settings.flight_scale
        } else {
            1.0
        };
        let v = sd * sd;
        let delta = f64::from(flight - self.origin);
        let floor = self.scale_floor(settings);
        for (fit, growth) in self.fits.iter_mut().zip(GROWTH_MODELS.iter()) {
            fit.update(
                growth.shape(delta),
                f64::from(value),
                v,
                self.observations,
                floor,
                settings,
            );
        }
        self.precision += 1.0 / v;
        self.newest = flight;
        self.observations += 1;
        true
    }

    /// Component `i`'s trend over `records` (oldest first; records outside the monitor
    /// model's domain are left out): the replay the controller does one fault at a time, in
    /// 976 bytes instead of a whole [`HealthTrend`].
    pub fn from_records<'r>(
        records: impl IntoIterator<Item = &'r HealthRecord>,
        i: usize,
        settings: &TrendSettings,
    ) -> Self {
        let mut trend = Self::new();
        trend.replay(records, i, settings);
        trend
    }

    /// [`Self::from_records`] in place: this trend is emptied and fed `records`.
    pub fn replay<'r>(
        &mut self,
        records: impl IntoIterator<Item = &'r HealthRecord>,
        i: usize,
        settings: &TrendSettings,
    ) {
        self.clear();
        for r in records.into_iter().filter(|r| r.is_trusted()) {
            self.add(r, i, settings);
        }
    }

    /// Empties the trend in place (the controller reuses one trend for every fault instead
    /// of building 976 bytes per fault).
    pub fn clear(&mut self) {
        self.origin = 0;
        self.newest = 0;
        self.observations = 0;
        self.precision = 0.0;
        for f in self.fits.iter_mut() {
            *f = ShapeFit::PRIOR;
        }
    }

    /// Adds quantity `i` of `record` ([`TREND_NAMES`]: a component's deviation from nominal,
    /// or the weak magnet's depth, each with its standard deviation): a preflight, or a
    /// flight's reading as an in-flight entry (each component it states a deviation for: one
    /// it holds at its preflight's is the preflight's, as its weak magnet always is); a
    /// window's own entry is ignored (its flight's reading carries it). Whether the record is
    /// trusted is the caller's to judge. Returns false when ignored (see [`Self::update`]).
    pub fn add(&mut self, record: &HealthRecord, i: usize, settings: &TrendSettings) -> bool {
        if record.is_window() {
            return false;
        }
        let std = if i == WEAK_MAGNET_TREND {
            let none = record.magnet.magnets().is_none();
            // A flight's reading holds its preflight's magnet: it adds nothing. Before the
            // first weak magnet read, a reading of none says only that the depth is below what
            // the search reads: the trend starts at the first magnet.
            if record.window != 0 || (none && self.observations == 0) {
                return false;
            }
            // A preflight that read none after one was read: any depth the search would not
            // have read is as likely, up to its first steps.
            if none {
                Some(NO_MAGNET_STD)
            } else {
                record.magnet.std()
            }
        } else {
            record.std.get(i)
        };
        match trended_value(record, i) {
            Some(value) => self.update(record.flight, record.window != 0, value, std, settings),
            None => false,
        }
    }

    fn fit(&self, i: usize) -> ShapeFit {
        self.fits.get(i).copied().unwrap_or(ShapeFit::PRIOR)
    }

    /// The least `ŝ²`: the typical observation's standard deviation is not read below
    /// [`TrendSettings::noise_floor`] (the stated deviations may overstate the scatter,
    /// never understate the floor).
    fn scale_floor(&self, settings: &TrendSettings) -> f64 {
        if self.observations == 0 || self.precision <= 0.0 {
            return 1.0;
        }
        settings.noise_floor * settings.noise_floor * self.precision / f64::from(self.observations)
    }

    fn growth(i: usize) -> Growth {
        GROWTH_MODELS.get(i).copied().unwrap_or(Growth::Linear)
    }

    /// Each shape's posterior weight (summing to 1), and the likeliest shape.
    pub fn weights(&self, settings: &TrendSettings) -> ([f64; MODEL_COUNT], usize) {
        let best = self
            .fits
            .iter()
            .map(|f| f.chi2)
            .fold(f64::INFINITY, |m, s| if s < m { s } else { m });
        let dof = self.observations.saturating_sub(2).max(1) as f64;
        let floor = self.scale_floor(settings);
        let scale = if best / dof > floor {
            best / dof
        } else {
            floor
        };
        let mut w = [0.0; MODEL_COUNT];
        let mut total = 0.0;
        for (i, (o, f)) in w.iter_mut().zip(self.fits.iter()).enumerate() {
            *o = Self::growth(i).prior() * exp64(-0.5 * (f.chi2 - best) / scale);
            total += *o;
        }
        let mut likeliest = 0;
        let mut top = 0.0;
        for (i, o) in w.iter_mut().enumerate() {
            *o /= total;
            if *o > top {
                top = *o;
                likeliest = i;
            }
        }
        (w, likeliest)
    }

    /// What every prediction of one estimate shares, computed once: each shape's weight and
    /// scale, whether its growth coefficient is significantly positive (t > 2), and the
    /// Student's t widening.
    fn forecast(&self, settings: &TrendSettings) -> (Forecast, usize) {
        let (weights, likeliest) = self.weights(settings);
        let floor = self.scale_floor(settings);
        let mut scale = [0.0; MODEL_COUNT];
        let mut grows = [false; MODEL_COUNT];
        for (i, (s, g)) in scale.iter_mut().zip(grows.iter_mut()).enumerate() {
            let fit = self.fit(i);
            *s = fit.scale(self.observations, floor);
            let var = *s * fit.p[2];
            *g = fit.theta[1] > 0.0 && fit.theta[1] * fit.theta[1] > 4.0 * var;
        }
        let forecast = Forecast {
            weights,
            scale,
            grows,
            widen: t90(self.observations.saturating_sub(2)) / Z90,
        };
        (forecast, likeliest)
    }

    /// Shape `i`'s predicted level at `flight` and its standard deviation (fit, widened to
    /// Student's t, and the systematic error). A shape whose fit shows no significant growth
    /// does not vouch for growth: beyond the newest flight it predicts the level stays
    /// (a fast exponential of tiny amplitude explains a flat history as well as a line does,
    /// and would otherwise put every healthy component a few dozen flights from its
    /// threshold).
    fn predictive(
        &self,
        f: &Forecast,
        i: usize,
        flight: f64,
        settings: &TrendSettings,
    ) -> (f64, f64) {
        let fit = self.fit(i);
        let newest = f64::from(self.newest);
        let grows = f.grows.get(i).copied().unwrap_or(false);
        let flight = if flight > newest && !grows {
            newest
        } else {
            flight
        };
        let g = Self::growth(i).shape(flight - f64::from(self.origin));
        let scale = f.scale.get(i).copied().unwrap_or(1.0);
        let var =
            scale * fit.spread(g) * f.widen * f.widen + settings.systematic * settings.systematic;
        (fit.mean(g), sqrt64(var))
    }

    /// The likeliest shape's level at `flight` and its 90 % half-width.
    pub fn band(&self, flight: f64, settings: &TrendSettings) -> (f64, f64) {
        let (f, likeliest) = self.forecast(settings);
        let (m, sd) = self.predictive(&f, likeliest, flight, settings);
        (m, Z90 * sd)
    }

    /// The envelope of the 90 % bands of every shape with at least 1 % of the weight, at
    /// `flight` (the cone of the picture).
    pub fn envelope(&self, flight: f64, settings: &TrendSettings) -> (f64, f64) {
        let (f, _) = self.forecast(settings);
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for (i, &wi) in f.weights.iter().enumerate() {
            if wi >= 0.01 {
                let (m, sd) = self.predictive(&f, i, flight, settings);
                lo = lo.min(m - Z90 * sd);
                hi = hi.max(m + Z90 * sd);
            }
        }
        (lo, hi)
    }

    /// Probability that the level has reached `threshold` at `flight`, mixed over the
    /// shapes by the weights of `f`.
    fn reached(&self, f: &Forecast, threshold: f64, flight: f64, s: &TrendSettings) -> f64 {
        let mut p = 0.0;
        for (i, &wi) in f.weights.iter().enumerate() {
            if wi > NEGLIGIBLE_WEIGHT {
                let (m, sd) = self.predictive(f, i, flight, s);
                p += wi * normal_cdf((m - threshold) / sd);
            }
        }
        p
    }

    /// Flights from the newest until the probability of having reached `threshold` is `q`,
    /// given its values `grid` on the grid of `step` flights (module doc).
    fn quantile(
        &self,
        f: &Forecast,
        threshold: f64,
        q: f64,
        grid: &[f64; GRID_STEPS as usize + 1],
        step: f64,
        settings: &TrendSettings,
    ) -> Option<f64> {
        let now = f64::from(self.newest);
        let k = grid.iter().position(|&p| p >= q)?;
        if k == 0 {
            return Some(0.0);
        }
        let (mut lo, mut hi) = ((k - 1) as f64 * step, k as f64 * step);
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if self.reached(f, threshold, now + mid, settings) >= q {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Some(hi)
    }

    /// The trend and, with a threshold, the RUL; `None` before three observations.
    pub fn estimate(
        &self,
        threshold: Option<f32>,
        settings: &TrendSettings,
    ) -> Option<TrendEstimate> {
        if self.observations < 3 {
            return None;
        }
        let (f, likeliest) = self.forecast(settings);
        let fit = self.fit(likeliest);
        let growth = Self::growth(likeliest);
        let delta = f64::from(self.newest - self.origin);
        let rul = threshold.map(|t| {
            let t = f64::from(t);
            let step = f64::from(settings.horizon.div_ceil(GRID_STEPS).max(1));
            let now = f64::from(self.newest);
            let mut grid = [0.0; GRID_STEPS as usize + 1];
            for (k, g) in grid.iter_mut().enumerate() {
                *g = self.reached(&f, t, now + k as f64 * step, settings);
            }
            let horizon = f64::from(settings.horizon);
            let at = |q: f64| {
                self.quantile(&f, t, q, &grid, step, settings)
                    .filter(|&x| x <= horizon)
                    .map(|x| x as f32)
            };
            RulEstimate {
                rul: at(0.5),
                lower: at(0.05),
                upper: at(0.95),
            }
        });
        let typical = if self.precision > 0.0 {
            f64::from(self.observations) / self.precision
        } else {
            settings.noise_floor * settings.noise_floor
        };
        Some(TrendEstimate {
            observations: self.observations,
            outliers: fit.outliers,
            newest: self.newest,
            growth,
            weight: f.weights.get(likeliest).copied().unwrap_or(0.0) as f32,
            level: fit.mean(growth.shape(delta)) as f32,
            slope: (fit.theta[1] * growth.slope(delta)) as f32,
            scatter: sqrt64(typical * f.scale.get(likeliest).copied().unwrap_or(1.0)) as f32,
            rul,
        })
    }
}

/// Every fault's trend, fed by trusted health records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HealthTrend {
    faults: [FaultTrend; TREND_COUNT],
    /// Records ignored: outside the monitor model's domain, or not newer.
    skipped: u32,
}

impl Default for HealthTrend {
    fn default() -> Self {
        Self::new()
    }
}

impl HealthTrend {
    pub const fn new() -> Self {
        Self {
            faults: [FaultTrend::new(); TREND_COUNT],
            skipped: 0,
        }
    }

    /// Replays records oldest first.
    pub fn from_records<'r>(
        records: impl IntoIterator<Item = &'r HealthRecord>,
        settings: &TrendSettings,
    ) -> Self {
        let mut trend = Self::new();
        for r in records {
            trend.update(r, settings);
        }
        trend
    }

    /// Adds one record: each fault's deviation from nominal feeds its trend with the record's
    /// standard deviation. A record outside the monitor model's domain is counted and
    /// ignored; a window's own entry is ignored (its flight's reading carries it).
    /// O(TREND_COUNT · MODEL_COUNT).
    pub fn update(&mut self, record: &HealthRecord, settings: &TrendSettings) {
        if record.is_window() {
            return;
        }
        if !record.is_trusted() {
            self.skipped += 1;
            return;
        }
        let mut taken = false;
        for (i, trend) in self.faults.iter_mut().enumerate() {
            taken |= trend.add(record, i, settings);
        }
        if !taken {
            self.skipped += 1;
        }
    }

    pub fn skipped(&self) -> u32 {
        self.skipped
    }

    /// Component `i`'s trend (the eccentricity phase's stays empty).
    pub fn fault(&self, i: usize) -> Option<&FaultTrend> {
        self.faults.get(i)
    }

    /// Every component's estimate (`None` for the eccentricity phase and before three
    /// trusted observations).
    pub fn estimates(&self, settings: &TrendSettings) -> [Option<TrendEstimate>; TREND_COUNT] {
        let mut out = [None; TREND_COUNT];
        for (i, (o, trend)) in out.iter_mut().zip(self.faults.iter()).enumerate() {
            if is_trended(i) {
                *o = trend.estimate(settings.threshold(i), settings);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests;
