//! Degradation trends and remaining useful life (RUL), per fault, from the health log.
//!
//! Units: time in flights (one preflight per flight), fault level in the fault vector's
//! normalised deviation from nominal ([`crate::fault::FaultVector::deviations`]), RUL in flights.
//!
//! ## Model
//!
//! Each fault's level is `y(t) = a + b·g_r(t − t₀) + ε`, with `g_0(Δ) = Δ` (linear) and
//! `g_r(Δ) = (e^{rΔ} − 1)/r` (exponential growth at rate `r` per flight, the shape of MATLAB's
//! `exponentialDegradationModel` with an offset), `t₀` the first flight seen. For each rate of
//! the fixed grid [`GROWTH_RATES`] a recursive least-squares filter (the Bayesian linear
//! update with a flat prior) refines `(a, b)` and its covariance once per observation, O(1).
//! The estimate picks the slowest rate whose residual is within `1 + 1/(n − 2)` of the best
//! (the simplest shape the data allow), and the RUL interval takes the union over every rate
//! still plausible (`1 + 3/(n − 2)`), so that the uncertain shape widens the interval.
//!
//! * **Scatter.** The residual variance is estimated from the data, floored at
//!   [`TrendSettings::noise_floor`] (the FDI's resolution); bands use Student's t at 90 %.
//! * **Outliers.** From the fourth observation on, an observation whose standardised
//!   prediction error `z` exceeds [`TrendSettings::outlier_z`] = c is down-weighted by
//!   `(c/z)²`, so its pull is bounded whatever its size (it is counted in
//!   [`TrendEstimate::outliers`]).
//!
//! ## RUL
//!
//! From the newest flight, the flights until the fitted level reaches the threshold
//! (`rul`), until its upper 90 % band does (`lower`), and until its lower band does (`upper`).
//! The crossing is searched flight by flight up to [`TrendSettings::horizon`] and refined by
//! bisection: `None` means beyond the horizon, `0` means reached already.
//!
//! Work bounds: [`FaultTrend::update`] O([`RATE_COUNT`]); [`FaultTrend::estimate`]
//! O(`RATE_COUNT · (horizon + 40)`) evaluations of one curve point. State: 680 bytes per
//! fault. All in f64 from IEEE operations ([`crate::math::exp64`], [`crate::math::sqrt64`]):
//! the same bits on the host and on the controller.

use crate::fault::{CIRCULAR, FAULT_COUNT};
use crate::health::HealthRecord;
use crate::math::{exp64, sqrt64};

/// Number of growth rates tried.
pub const RATE_COUNT: usize = 12;

/// Growth rates tried [1/flight]: 0 (linear), then geometric from 0.01 to 0.3.
pub const GROWTH_RATES: [f64; RATE_COUNT] = [
    0.0, 0.01, 0.0136, 0.0186, 0.0254, 0.0346, 0.0472, 0.0644, 0.0879, 0.1199, 0.1636, 0.3,
];

/// Prior variance of `(a, b)` relative to the noise variance: flat.
const PRIOR_VARIANCE: f64 = 1.0e6;

/// Observations before outliers are judged (the residual variance needs some).
const OUTLIER_AFTER: u32 = 4;

/// Bisection steps that refine a crossing inside its flight (2⁻²⁴ flight).
const BISECTION_STEPS: u32 = 24;

/// How trends are judged and RUL computed.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrendSettings {
    /// Maintenance threshold on each component's deviation from nominal; NaN or ≤ 0: no RUL
    /// for that component (the eccentricity phase is never trended).
    pub thresholds: [f32; FAULT_COUNT],
    /// Least residual standard deviation assumed: the FDI's own error on one test, which is
    /// partly systematic (it does not average out along a history).
    pub noise_floor: f64,
    /// Standardised prediction error beyond which an observation is down-weighted.
    pub outlier_z: f64,
    /// Flights searched for a crossing.
    pub horizon: u32,
}

impl TrendSettings {
    /// Illustrative maintenance thresholds (the actuator maker sets its own): friction 0.5,
    /// backlash 0.5, each short 0.3, eccentricity 0.5, gain drift ±0.25.
    pub const DEFAULT: Self = Self {
        thresholds: [0.5, 0.5, 0.3, 0.3, 0.3, 0.5, f32::NAN, 0.25],
        // Single-fault identification errors reach ~0.01 (docs/accuracy.md, Table I).
        noise_floor: 0.01,
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

/// Whether component `i` has a trend (every fault component; not the eccentricity phase,
/// which is a location).
pub fn is_trended(i: usize) -> bool {
    !CIRCULAR.get(i).copied().unwrap_or(true)
}

/// One rate's recursive least-squares state.
#[derive(Clone, Copy, Debug, PartialEq)]
struct RateFit {
    /// `(a, b)`.
    theta: [f64; 2],
    /// Covariance over the noise variance: `[p_aa, p_ab, p_bb]`.
    p: [f64; 3],
    /// Weighted sum of squared standardised prediction errors (the RLS residual sum).
    sse: f64,
    outliers: u32,
}

impl RateFit {
    const PRIOR: Self = Self {
        theta: [0.0, 0.0],
        p: [PRIOR_VARIANCE, 0.0, PRIOR_VARIANCE],
        sse: 0.0,
        outliers: 0,
    };

    fn mean(&self, g: f64) -> f64 {
        self.theta[0] + self.theta[1] * g
    }

    /// `φᵀPφ` for `φ = (1, g)`.
    fn spread(&self, g: f64) -> f64 {
        self.p[0] + 2.0 * self.p[1] * g + self.p[2] * g * g
    }

    fn variance(&self, n: u32, floor: f64) -> f64 {
        let dof = n.saturating_sub(2).max(1) as f64;
        let v = self.sse / dof;
        if v > floor * floor {
            v
        } else {
            floor * floor
        }
    }

    fn update(&mut self, g: f64, y: f64, n_before: u32, settings: &TrendSettings) {
        let s = self.spread(g);
        let e = y - self.mean(g);
        let mut w = 1.0;
        if n_before >= OUTLIER_AFTER {
            let var = self.variance(n_before, settings.noise_floor) * (1.0 + s);
            let c = settings.outlier_z;
            if e * e > c * c * var {
                w = c * c * var / (e * e);
                self.outliers += 1;
            }
        }
        // Gain K = Pφ / (1/w + φᵀPφ); P ← P − K φᵀP.
        let pg0 = self.p[0] + self.p[1] * g;
        let pg1 = self.p[1] + self.p[2] * g;
        let denom = 1.0 / w + s;
        let k0 = pg0 / denom;
        let k1 = pg1 / denom;
        self.theta[0] += k0 * e;
        self.theta[1] += k1 * e;
        self.p = [
            self.p[0] - k0 * pg0,
            self.p[1] - k0 * pg1,
            self.p[2] - k1 * pg1,
        ];
        self.sse += w * e * e / (1.0 + w * s);
    }
}

/// `g_r(Δ)`: the growth shape at rate `r` after `Δ` flights.
fn shape(rate: f64, delta: f64) -> f64 {
    if rate == 0.0 {
        delta
    } else {
        (exp64(rate * delta) - 1.0) / rate
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

/// Which curve a crossing is searched on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Curve {
    Level,
    Upper,
    Lower,
}

/// One fault's trend: every rate's filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultTrend {
    origin: u32,
    newest: u32,
    observations: u32,
    fits: [RateFit; RATE_COUNT],
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
    /// Flights until the fitted level reaches the threshold.
    pub rul: Option<f32>,
    /// 90 % interval: until the upper band reaches it (over every plausible rate)...
    pub lower: Option<f32>,
    /// ...and until the lower band does.
    pub upper: Option<f32>,
}

/// The trend of one fault after the newest observation.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrendEstimate {
    pub observations: u32,
    /// Observations down-weighted as outliers (by the chosen rate's filter).
    pub outliers: u32,
    /// Newest flight seen.
    pub newest: u32,
    /// Chosen growth rate [1/flight]; 0 is linear.
    pub rate: f32,
    /// Fitted level at the newest flight.
    pub level: f32,
    /// Fitted growth per flight at the newest flight.
    pub slope: f32,
    /// Residual standard deviation (floored).
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
            fits: [RateFit::PRIOR; RATE_COUNT],
        }
    }

    pub fn observations(&self) -> u32 {
        self.observations
    }

    /// Adds the level `value` observed at `flight`. Flights must increase; an older or
    /// repeated flight, or a non-finite value, is ignored (returns false). O(RATE_COUNT).
    pub fn update(&mut self, flight: u32, value: f32, settings: &TrendSettings) -> bool {
        if !value.is_finite() || (self.observations > 0 && flight <= self.newest) {
            return false;
        }
        if self.observations == 0 {
            self.origin = flight;
        }
        let delta = f64::from(flight - self.origin);
        for (fit, &rate) in self.fits.iter_mut().zip(GROWTH_RATES.iter()) {
            fit.update(
                shape(rate, delta),
                f64::from(value),
                self.observations,
                settings,
            );
        }
        self.newest = flight;
        self.observations += 1;
        true
    }

    /// Component `i`'s trend over `records` (oldest first; records outside the monitor
    /// model's domain are left out): the replay the controller does one fault at a time, in
    /// 680 bytes instead of a whole [`HealthTrend`].
    pub fn from_records<'r>(
        records: impl IntoIterator<Item = &'r HealthRecord>,
        i: usize,
        settings: &TrendSettings,
    ) -> Self {
        let mut trend = Self::new();
        for r in records.into_iter().filter(|r| r.is_trusted()) {
            if let Some(Some(d)) = r.faults.deviations().get(i) {
                trend.update(r.flight, *d, settings);
            }
        }
        trend
    }

    /// Index of the chosen rate and the plausibility bound on the residual.
    fn choice(&self) -> (usize, f64) {
        let best = self
            .fits
            .iter()
            .map(|f| f.sse)
            .fold(f64::INFINITY, |m, s| if s < m { s } else { m });
        let dof = self.observations.saturating_sub(2).max(1) as f64;
        let chosen = self
            .fits
            .iter()
            .position(|f| f.sse <= best * (1.0 + 1.0 / dof))
            .unwrap_or(0);
        (chosen, best * (1.0 + 3.0 / dof))
    }

    fn fit(&self, i: usize) -> RateFit {
        self.fits.get(i).copied().unwrap_or(RateFit::PRIOR)
    }

    /// The chosen fit's level at `flight` and its 90 % half-width.
    pub fn band(&self, flight: f64, settings: &TrendSettings) -> (f64, f64) {
        let (chosen, _) = self.choice();
        self.band_of(chosen, flight, settings)
    }

    fn band_of(&self, i: usize, flight: f64, settings: &TrendSettings) -> (f64, f64) {
        let fit = self.fit(i);
        let rate = GROWTH_RATES.get(i).copied().unwrap_or(0.0);
        let g = shape(rate, flight - f64::from(self.origin));
        let var = fit.variance(self.observations, settings.noise_floor) * fit.spread(g);
        let dof = self.observations.saturating_sub(2);
        (fit.mean(g), t90(dof) * sqrt64(var))
    }

    /// Whether rate `i`'s growth coefficient is significantly positive (t > 2): a rate whose
    /// fit shows no growth cannot vouch for exponential growth at that rate.
    fn grows(&self, i: usize, settings: &TrendSettings) -> bool {
        let fit = self.fit(i);
        let var = fit.variance(self.observations, settings.noise_floor) * fit.p[2];
        fit.theta[1] > 0.0 && fit.theta[1] * fit.theta[1] > 4.0 * var
    }

    /// The envelope of the 90 % bands of the chosen rate and of every other plausible rate
    /// that shows growth, at `flight` (the RUL cone).
    pub fn envelope(&self, flight: f64, settings: &TrendSettings) -> (f64, f64) {
        let (chosen, plausible) = self.choice();
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for (i, fit) in self.fits.iter().enumerate() {
            if i == chosen || (fit.sse <= plausible && self.grows(i, settings)) {
                let (m, h) = self.band_of(i, flight, settings);
                lo = lo.min(m - h);
                hi = hi.max(m + h);
            }
        }
        (lo, hi)
    }

    /// The curve of rate `i` at `flight`: its fitted level, or its upper or lower 90 % band.
    fn curve(&self, i: usize, curve: Curve, flight: f64, settings: &TrendSettings) -> f64 {
        let (m, w) = self.band_of(i, flight, settings);
        match curve {
            Curve::Level => m,
            Curve::Upper => m + w,
            Curve::Lower => m - w,
        }
    }

    /// Flights from the newest until rate `i`'s `curve` reaches `threshold` (module doc).
    fn crossing(
        &self,
        i: usize,
        curve: Curve,
        threshold: f64,
        settings: &TrendSettings,
    ) -> Option<f64> {
        let at = |x: f64| self.curve(i, curve, x, settings) >= threshold;
        let now = f64::from(self.newest);
        if at(now) {
            return Some(0.0);
        }
        let mut before = now;
        for step in 1..=settings.horizon {
            let x = now + f64::from(step);
            if at(x) {
                let (mut lo, mut hi) = (before, x);
                for _ in 0..BISECTION_STEPS {
                    let mid = 0.5 * (lo + hi);
                    if at(mid) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return Some(hi - now);
            }
            before = x;
        }
        None
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
        let (chosen, plausible) = self.choice();
        let fit = self.fit(chosen);
        let rate = GROWTH_RATES.get(chosen).copied().unwrap_or(0.0);
        let delta = f64::from(self.newest - self.origin);
        let rul = threshold.map(|t| {
            let t = f64::from(t);
            let rul = self.crossing(chosen, Curve::Level, t, settings);
            let mut lower: Option<f64> = None;
            let mut upper: Option<f64> = Some(0.0);
            for (i, f) in self.fits.iter().enumerate() {
                if i != chosen && !(f.sse <= plausible && self.grows(i, settings)) {
                    continue;
                }
                let first = self.crossing(i, Curve::Upper, t, settings);
                let last = self.crossing(i, Curve::Lower, t, settings);
                lower = match (lower, first) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                };
                upper = match (upper, last) {
                    (Some(a), Some(b)) => Some(a.max(b)),
                    _ => None,
                };
            }
            RulEstimate {
                rul: rul.map(|r| r as f32),
                lower: lower.map(|r| r as f32),
                upper: upper.map(|r| r as f32),
            }
        });
        Some(TrendEstimate {
            observations: self.observations,
            outliers: fit.outliers,
            newest: self.newest,
            rate: rate as f32,
            level: fit.mean(shape(rate, delta)) as f32,
            slope: (fit.theta[1] * exp64(rate * delta)) as f32,
            scatter: sqrt64(fit.variance(self.observations, settings.noise_floor)) as f32,
            rul,
        })
    }
}

/// Every fault's trend, fed by trusted health records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HealthTrend {
    faults: [FaultTrend; FAULT_COUNT],
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
            faults: [FaultTrend::new(); FAULT_COUNT],
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

    /// Adds one record: each fault's deviation from nominal feeds its trend. A record outside
    /// the monitor model's domain is counted and ignored. O(FAULT_COUNT · RATE_COUNT).
    pub fn update(&mut self, record: &HealthRecord, settings: &TrendSettings) {
        if !record.is_trusted() {
            self.skipped += 1;
            return;
        }
        let mut taken = false;
        for (trend, d) in self.faults.iter_mut().zip(record.faults.deviations()) {
            if let Some(d) = d {
                taken |= trend.update(record.flight, d, settings);
            }
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
    pub fn estimates(&self, settings: &TrendSettings) -> [Option<TrendEstimate>; FAULT_COUNT] {
        let mut out = [None; FAULT_COUNT];
        for (i, (o, trend)) in out.iter_mut().zip(self.faults.iter()).enumerate() {
            if is_trended(i) {
                *o = trend.estimate(settings.threshold(i), settings);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fault::FaultVector;

    /// A deterministic scatter in ±`amp` (no RNG needed).
    fn wiggle(i: u32, amp: f32) -> f32 {
        amp * (((i * 7919 + 13) % 101) as f32 / 50.0 - 1.0)
    }

    fn feed(levels: impl Fn(u32) -> f32, flights: u32) -> FaultTrend {
        let s = TrendSettings::DEFAULT;
        let mut t = FaultTrend::new();
        for f in 0..flights {
            assert!(t.update(100 + f, levels(f), &s));
        }
        t
    }

    #[test]
    fn exact_line_gives_the_exact_rul() {
        // 0.01 per flight from 0.05: reaches 0.5 at flight 45; 20 flights seen (0..19).
        let t = feed(|f| 0.05 + 0.01 * f as f32, 20);
        let e = t.estimate(Some(0.5), &TrendSettings::DEFAULT).unwrap();
        assert_eq!(e.rate, 0.0);
        let r = e.rul.unwrap();
        assert!((r.rul.unwrap() - 26.0).abs() < 0.05, "{r:?}");
        assert!(
            r.lower.unwrap() <= 26.0 && r.upper.unwrap() >= 26.0,
            "{r:?}"
        );
        assert!((e.slope - 0.01).abs() < 1e-4 && (e.level - 0.24).abs() < 1e-3);
    }

    #[test]
    fn exponential_growth_is_recognised() {
        // y = 0.02·e^{0.0879 f}: reaches 0.5 at f = ln(25)/0.0879 = 36.6; 25 flights seen.
        let y = |f: u32| 0.02 * (0.0879 * f as f64).exp() as f32;
        let t = feed(y, 25);
        let e = t.estimate(Some(0.5), &TrendSettings::DEFAULT).unwrap();
        assert!(e.rate > 0.05, "{e:?}");
        let truth = (25.0f64).ln() / 0.0879 - 24.0;
        let rul = e.rul.unwrap().rul.unwrap() as f64;
        assert!((rul - truth).abs() < 0.1 * truth, "rul {rul} truth {truth}");
    }

    #[test]
    fn scatter_widens_the_interval_and_the_truth_stays_inside() {
        let clean = feed(|f| 0.1 + 0.01 * f as f32, 20);
        let noisy = feed(|f| 0.1 + 0.01 * f as f32 + wiggle(f, 0.02), 20);
        let s = TrendSettings::DEFAULT;
        let width = |t: &FaultTrend| {
            let r = t.estimate(Some(0.5), &s).unwrap().rul.unwrap();
            (r.lower.unwrap(), r.upper.unwrap())
        };
        let (cl, cu) = width(&clean);
        let (nl, nu) = width(&noisy);
        assert!(
            nu - nl > 3.0 * (cu - cl),
            "clean {cl}..{cu}, noisy {nl}..{nu}"
        );
        // Truth: reaches 0.5 at flight 40, i.e. 21 flights after the newest (19).
        assert!(nl <= 21.0 && nu >= 21.0, "noisy {nl}..{nu}");
    }

    #[test]
    fn one_outlier_barely_moves_the_rul() {
        let base = |f: u32| 0.1 + 0.01 * f as f32 + wiggle(f, 0.004);
        let s = TrendSettings::DEFAULT;
        let clean = feed(base, 20).estimate(Some(0.5), &s).unwrap();
        let hit = feed(|f| if f == 12 { base(f) + 0.4 } else { base(f) }, 20)
            .estimate(Some(0.5), &s)
            .unwrap();
        assert_eq!(hit.outliers, 1);
        let a = clean.rul.unwrap().rul.unwrap();
        let b = hit.rul.unwrap().rul.unwrap();
        assert!((a - b).abs() < 0.1 * a, "clean {a}, with outlier {b}");
        // Without the down-weighting the same outlier moves it far more.
        let mut no_guard = s;
        no_guard.outlier_z = f64::INFINITY;
        let mut t = FaultTrend::new();
        for f in 0..20 {
            t.update(
                100 + f,
                if f == 12 { base(f) + 0.4 } else { base(f) },
                &no_guard,
            );
        }
        let c = t
            .estimate(Some(0.5), &no_guard)
            .unwrap()
            .rul
            .unwrap()
            .rul
            .unwrap();
        assert!((a - c).abs() > 3.0 * (a - b).abs(), "unguarded {c}");
    }

    #[test]
    fn flat_levels_have_no_rul_and_reached_levels_have_zero() {
        let s = TrendSettings::DEFAULT;
        let flat = feed(|f| 0.02 + wiggle(f, 0.003), 15)
            .estimate(Some(0.5), &s)
            .unwrap();
        assert_eq!(flat.rul.unwrap().rul, None);
        let over = feed(|f| 0.6 + 0.001 * f as f32, 5)
            .estimate(Some(0.5), &s)
            .unwrap();
        assert_eq!(over.rul.unwrap().rul, Some(0.0));
        assert!(FaultTrend::new().estimate(Some(0.5), &s).is_none());
    }

    #[test]
    fn the_past_and_non_finite_values_are_ignored() {
        let s = TrendSettings::DEFAULT;
        let mut t = FaultTrend::new();
        assert!(t.update(5, 0.1, &s));
        assert!(!t.update(5, 0.2, &s));
        assert!(!t.update(4, 0.2, &s));
        assert!(!t.update(6, f32::NAN, &s));
        assert_eq!(t.observations(), 1);
    }

    #[test]
    fn records_outside_the_domain_do_not_feed_the_trend() {
        use crate::domain::{Domain, OutsideReason};
        let s = TrendSettings::DEFAULT;
        let mut k = *FaultVector::NOMINAL.as_array();
        let mut trend = HealthTrend::new();
        for f in 0..6u32 {
            k[0] = 0.1 + 0.02 * f as f32;
            let domain = if f == 3 {
                Domain::Outside(OutsideReason::NoMotion { travel: 0.0 })
            } else {
                Domain::Within
            };
            let r = HealthRecord::new(f, FaultVector::new(k).unwrap(), 0.01, domain);
            trend.update(&r, &s);
        }
        assert_eq!(trend.skipped(), 1);
        assert_eq!(trend.fault(0).unwrap().observations(), 5);
        let e = trend.estimates(&s);
        assert!(e[6].is_none(), "the eccentricity phase has no trend");
        assert!(e[0].unwrap().rul.unwrap().rul.is_some());
        assert!(e[1].unwrap().rul.unwrap().rul.is_none());
    }
}
