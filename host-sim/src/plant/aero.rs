//! The control surface's aerodynamics and the wind on a parked surface (SPEC §10, issue 36).
//!
//! The hinge moment is `H = q·S·c·(C_h0 + C_hα·α + C_hδ·δ)` [N·m] on the user shaft, with
//! `q = ½·ρ·V²` [Pa], `δ` the surface's deflection [rad] and `α` the flow's incidence on it
//! [rad]. On the ground, parked, `α` is the wind's incidence on the surface (set by where the
//! wind comes from) and `V` the wind's speed: a mean, low-altitude Dryden turbulence
//! (MIL-F-8785C, longitudinal, at the surface's height) and discrete (1 − cos) gusts up to a
//! peak, at random times. [`GroundWind::speeds`] draws one value per control period (the
//! wind's spectrum ends far below the 10 kHz control rate); O(samples) work, seeded.

use crate::plant::noise::Gaussian;

/// One knot [m/s].
pub const KNOT: f64 = 0.514_444;

/// What the surface's aerodynamics are (`[surface]` of an actuator file): the reference model
/// plays them, the FDI never reads them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceAerodynamics {
    /// Planform area of the surface [m²].
    pub area: f64,
    /// The surface's mean chord aft of its hinge line [m].
    pub chord: f64,
    /// Hinge-moment coefficients: at zero incidence and deflection, per radian of incidence,
    /// per radian of deflection.
    pub ch0: f64,
    pub ch_alpha: f64,
    pub ch_delta: f64,
    /// Air density [kg/m³].
    pub air_density: f64,
    /// Incidence of the wind on the parked surface [rad] (a wind from ahead on a level
    /// surface is 0; a quartering wind on a fin or a tail's elevator is tens of degrees).
    pub parked_incidence: f64,
}

impl SurfaceAerodynamics {
    /// The reference actuator's surface: an aileron of 3 m² with 0.6 m of chord aft of the
    /// hinge; a 30 kt wind at 20° of incidence holds it with ≈ 55 N·m, a fifth of the moment
    /// the preflight chirp's 5 mrad takes from the hinge spring (250 N·m).
    pub const REFERENCE: Self = Self {
        area: 3.0,
        chord: 0.6,
        ch0: 0.0,
        ch_alpha: -0.6,
        ch_delta: -0.9,
        air_density: 1.225,
        parked_incidence: 20.0 * core::f64::consts::PI / 180.0,
    };

    /// `q·S·c` at wind speed `speed` [m/s]: the moment per unit hinge-moment coefficient
    /// [N·m].
    pub fn moment_scale(&self, speed: f64) -> f64 {
        0.5 * self.air_density * speed * speed * self.area * self.chord
    }

    /// The hinge moment [N·m] at `q·S·c` = `scale`, incidence `alpha` and deflection `delta`.
    pub fn hinge_moment(&self, scale: f64, alpha: f64, delta: f64) -> f64 {
        scale * (self.ch0 + self.ch_alpha * alpha + self.ch_delta * delta)
    }
}

impl Default for SurfaceAerodynamics {
    fn default() -> Self {
        Self::REFERENCE
    }
}

/// The wind over a parked aircraft during the preflight: a mean speed with low-altitude
/// turbulence, and gusts up to `gust_knots`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundWind {
    /// Mean wind speed [kt].
    pub mean_knots: f64,
    /// Peak gust speed [kt] (at least the mean; equal to it: a steady wind with turbulence
    /// only).
    pub gust_knots: f64,
}

/// Height of the surface above the ground [m], for the Dryden scale length.
const SURFACE_HEIGHT: f64 = 3.0;
/// Mean time between the starts of two discrete gusts on a gusty day [s].
const MEAN_GUST_INTERVAL: f64 = 3.0;
/// Shortest and longest discrete gust [s].
const GUST_DURATION: [f64; 2] = [0.3, 1.5];

impl GroundWind {
    /// A wind of `mean_knots` gusting to `gust_knots`; refused when negative, not finite or
    /// the gust below the mean.
    pub fn new(mean_knots: f64, gust_knots: f64) -> Result<Self, String> {
        if !(mean_knots.is_finite() && gust_knots.is_finite()) || mean_knots < 0.0 {
            return Err(format!(
                "wind {mean_knots} kt gusting {gust_knots} kt: speeds must be finite and ≥ 0"
            ));
        }
        if gust_knots < mean_knots {
            return Err(format!(
                "gusts of {gust_knots} kt below the mean wind of {mean_knots} kt"
            ));
        }
        Ok(Self {
            mean_knots,
            gust_knots,
        })
    }

    /// Standard deviation of the longitudinal turbulence [m/s]: MIL-F-8785C at low altitude,
    /// σ_w = 0.1·W₂₀ and σ_u = σ_w / (0.177 + 0.000823·h)^0.4 (h in ft), W₂₀ the mean wind.
    pub fn turbulence_sigma(&self) -> f64 {
        let h_ft = SURFACE_HEIGHT / 0.3048;
        0.1 * self.mean_knots * KNOT / (0.177 + 0.000823 * h_ft).powf(0.4)
    }

    /// The Dryden longitudinal scale length [m]: L_u = h / (0.177 + 0.000823·h)^1.2 (ft).
    pub fn scale_length(&self) -> f64 {
        let h_ft = SURFACE_HEIGHT / 0.3048;
        h_ft / (0.177 + 0.000823 * h_ft).powf(1.2) * 0.3048
    }

    /// The wind speed [m/s, ≥ 0] at each of `samples` control periods of `period` [s]:
    /// first-order Dryden turbulence started from its stationary distribution, plus (1 − cos)
    /// gusts of 0.3–1.5 s, each of 50–100 % of `gust − mean`, starting on average every 3 s
    /// from 2 s before the first sample (so one may be under way). Seeded; O(samples).
    pub fn speeds(&self, samples: usize, period: f64, seed: u64) -> Vec<f64> {
        let mut rng = Gaussian::new(seed ^ 0x0057_1D00_u64);
        let mean = self.mean_knots * KNOT;
        let sigma = self.turbulence_sigma();
        let v = mean.max(1.0);
        let a = (-v * period / self.scale_length()).exp();
        let drive = sigma * (1.0 - a * a).sqrt();
        let excess = (self.gust_knots - self.mean_knots) * KNOT;
        // The discrete gusts: (start, duration, amplitude) over the whole span.
        let span = samples as f64 * period;
        let mut gusts = Vec::new();
        if excess > 0.0 {
            let mut t = -2.0;
            loop {
                t += -MEAN_GUST_INTERVAL * rng.uniform().ln();
                if t >= span {
                    break;
                }
                let duration =
                    GUST_DURATION[0] + (GUST_DURATION[1] - GUST_DURATION[0]) * rng.uniform();
                let amplitude = excess * (0.5 + 0.5 * rng.uniform());
                gusts.push((t, duration, amplitude));
            }
        }
        let mut u = sigma * rng.next();
        (0..samples)
            .map(|k| {
                let t = k as f64 * period;
                let gust: f64 = gusts
                    .iter()
                    .filter(|(start, duration, _)| t >= *start && t < start + duration)
                    .map(|(start, duration, amplitude)| {
                        0.5 * amplitude
                            * (1.0 - (core::f64::consts::TAU * (t - start) / duration).cos())
                    })
                    .sum();
                let speed = (mean + u + gust).max(0.0);
                u = a * u + drive * rng.next();
                speed
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flight_window_has_its_phases_command_and_turbulence() {
        let period = 1e-4;
        for (phase, turbulence) in [
            (FlightPhase::Cruise, Turbulence::Light),
            (FlightPhase::Approach, Turbulence::Moderate),
        ] {
            let w = FlightWindow { phase, turbulence };
            // 200 s: many gust correlation times (L/V ≈ 2–4 s).
            let x = w.samples(2_000_000, period, 7);
            let n = x.len() as f64;
            let (rms, _) = phase.command_activity();
            // The tones' RMS over the first 20 s, the trim's slow change (a line) removed by
            // least squares.
            let first: Vec<(f64, f64)> = x[..200_000]
                .iter()
                .enumerate()
                .map(|(k, s)| (k as f64 * period, s.command))
                .collect();
            let m = first.len() as f64;
            let (st, sc) = first
                .iter()
                .fold((0.0, 0.0), |(a, b), (t, c)| (a + t, b + c));
            let (tm, cm) = (st / m, sc / m);
            let slope = first.iter().map(|(t, c)| (t - tm) * (c - cm)).sum::<f64>()
                / first.iter().map(|(t, _)| (t - tm).powi(2)).sum::<f64>();
            let spread = (first
                .iter()
                .map(|(t, c)| (c - cm - slope * (t - tm)).powi(2))
                .sum::<f64>()
                / m)
                .sqrt();
            assert!(
                spread > 0.5 * rms && spread < 2.0 * rms,
                "{phase:?}: {spread} vs {rms}"
            );
            let gust: Vec<f64> = x
                .iter()
                .map(|s| (s.incidence - phase.trim_incidence()) * phase.airspeed())
                .collect();
            let g_mean = gust.iter().sum::<f64>() / n;
            let sigma = (gust.iter().map(|g| (g - g_mean).powi(2)).sum::<f64>() / n).sqrt();
            let want = turbulence.sigma();
            assert!(
                (sigma - want).abs() < 0.25 * want,
                "{phase:?} {turbulence:?}: σ_w {sigma} m/s, Dryden's {want}"
            );
            // Zero mean within four standard errors of a 200 s mean (≈ σ·√(2τ/T)).
            let tau = phase.scale_length() / phase.airspeed();
            let bound = 4.0 * want * (2.0 * tau / (n * period)).sqrt();
            assert!(
                g_mean.abs() < bound,
                "{phase:?}: mean {g_mean} m/s, bound {bound}"
            );
        }
    }

    #[test]
    fn thirty_knots_hold_the_reference_surface_with_a_fifth_of_the_chirps_moment() {
        let s = SurfaceAerodynamics::REFERENCE;
        let h = s.hinge_moment(s.moment_scale(30.0 * KNOT), s.parked_incidence, 0.0);
        assert!((-60.0..-50.0).contains(&h), "{h}");
    }

    #[test]
    fn gusts_reach_their_peak_and_a_steady_wind_keeps_its_mean() {
        let gusty = GroundWind::new(15.0, 30.0).unwrap();
        let v = gusty.speeds(200_000, 1e-4, 3);
        let peak = v.iter().copied().fold(0.0, f64::max) / KNOT;
        assert!((24.0..40.0).contains(&peak), "peak {peak} kt");
        let steady = GroundWind::new(20.0, 20.0).unwrap();
        let v = steady.speeds(2_000_000, 1e-4, 3);
        let mean = v.iter().sum::<f64>() / v.len() as f64 / KNOT;
        // 200 s of Dryden turbulence (σ ≈ 4 kt, a 2.3 s correlation time): the mean within
        // 10 % (≈ 3 standard errors).
        assert!((18.0..22.0).contains(&mean), "mean {mean} kt");
        let sd = (v.iter().map(|x| (x / KNOT - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
        assert!(sd > 1.0 && sd < 8.0, "σ {sd} kt");
        assert!(GroundWind::new(20.0, 10.0).is_err());
        assert!(GroundWind::new(-1.0, 10.0).is_err());
        assert!(GroundWind::new(f64::NAN, 10.0).is_err());
    }
}

/// A flight phase: the dynamic pressure, airspeed and trim the surface flies at, and the
/// flight control computer's activity (SPEC §10, issue 36).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FlightPhase {
    /// Higher dynamic pressure (≈ 14 kPa), moderate corrections.
    Climb,
    /// ≈ 10 kPa, small corrections.
    Cruise,
    /// Low dynamic pressure (≈ 2.5 kPa), larger and faster corrections.
    Approach,
}

/// Turbulence intensity (MIL-F-8785C): the vertical gust's standard deviation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Turbulence {
    /// σ_w ≈ 1.5 m/s (5 ft/s).
    Light,
    /// σ_w ≈ 3 m/s (10 ft/s).
    Moderate,
}

impl FlightPhase {
    /// Dynamic pressure [Pa].
    pub fn dynamic_pressure(self) -> f64 {
        match self {
            Self::Climb => 14.0e3,
            Self::Cruise => 10.0e3,
            Self::Approach => 2.5e3,
        }
    }

    /// True airspeed [m/s].
    pub fn airspeed(self) -> f64 {
        match self {
            Self::Climb => 190.0,
            Self::Cruise => 230.0,
            Self::Approach => 70.0,
        }
    }

    /// The flow's incidence on the surface at trim [rad]: the trim bias of the hinge moment
    /// (on the reference surface ≈ 260 N·m in climb, ≈ 95 N·m in cruise and on the approach).
    pub fn trim_incidence(self) -> f64 {
        let deg = core::f64::consts::PI / 180.0;
        match self {
            Self::Climb => 1.0 * deg,
            Self::Cruise => 0.5 * deg,
            Self::Approach => 2.0 * deg,
        }
    }

    /// RMS of the flight control computer's corrections at the surface [rad] and their
    /// highest frequency [Hz].
    pub fn command_activity(self) -> (f64, f64) {
        match self {
            Self::Climb => (1.0e-3, 1.5),
            Self::Cruise => (0.5e-3, 1.0),
            Self::Approach => (3.0e-3, 2.0),
        }
    }

    /// The Dryden scale length of the vertical gust [m]: 533 m (1 750 ft) at altitude,
    /// 300 m on the approach.
    pub fn scale_length(self) -> f64 {
        match self {
            Self::Approach => 300.0,
            _ => 533.0,
        }
    }
}

impl Turbulence {
    /// Standard deviation of the vertical gust [m/s].
    pub fn sigma(self) -> f64 {
        match self {
            Self::Light => 1.5,
            Self::Moderate => 3.0,
        }
    }
}

/// A window of flight: what the reference model plays on the surface beyond the test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlightWindow {
    pub phase: FlightPhase,
    pub turbulence: Turbulence,
}

/// One control period of a flight window.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct FlightSample {
    /// The flight control computer's command at the surface [rad], to which the test adds.
    pub command: f64,
    /// The surface's incidence: trim plus the vertical gust's `w_g / V` [rad].
    pub incidence: f64,
}

/// Frequencies of the flight control computer's corrections: the command is their sum.
const COMMAND_TONES: usize = 12;

impl FlightWindow {
    /// `samples` control periods of `period` [s]: the command (a sum of 12 tones between
    /// 0.1 Hz and the phase's highest frequency, random phases and amplitudes, scaled to the
    /// phase's RMS, plus a slow trim change of up to ±2 mrad/s), and the incidence (trim plus
    /// the Dryden vertical gust, second-order form, over the airspeed). Seeded; O(samples).
    pub fn samples(&self, samples: usize, period: f64, seed: u64) -> Vec<FlightSample> {
        let mut rng = Gaussian::new(seed ^ 0x00F1_1647_u64);
        let (rms, top) = self.phase.command_activity();
        let tones: Vec<(f64, f64, f64)> = (0..COMMAND_TONES)
            .map(|_| {
                let f = 0.1 + (top - 0.1) * rng.uniform();
                let a = 0.5 + rng.uniform();
                let phi = core::f64::consts::TAU * rng.uniform();
                (f, a, phi)
            })
            .collect();
        // Σ a²/2 is the tones' mean square.
        let scale = rms / (tones.iter().map(|(_, a, _)| a * a / 2.0).sum::<f64>()).sqrt();
        let trim_rate = 2.0e-3 * (2.0 * rng.uniform() - 1.0);
        // Dryden vertical: H(s) = σ·√(L/(πV))·(1 + √3·(L/V)·s)/(1 + (L/V)·s)² on white noise
        // of spectral density π (its one-sided form in ω): √π·σ·√(L/V) on unit-intensity
        // noise, whose samples over a period Δt have the standard deviation 1/√Δt. Two
        // first-order stages, the lead taken on the second's input.
        let v = self.phase.airspeed();
        let tau = self.phase.scale_length() / v;
        let gain = self.turbulence.sigma() * tau.sqrt();
        let white = 1.0 / period.sqrt();
        let (mut x1, mut x2) = (0.0f64, 0.0f64);
        // Start the gust filter in its stationary state: run it 5 τ first.
        let warm = (5.0 * tau / period) as usize;
        let mut step = |rng: &mut Gaussian| {
            let u = gain * white * rng.next();
            let dx1 = (u - x1) / tau;
            x1 += period * dx1;
            let lead = x1 + 3f64.sqrt() * tau * dx1;
            x2 += period * (lead - x2) / tau;
            x2
        };
        for _ in 0..warm {
            step(&mut rng);
        }
        let trim = self.phase.trim_incidence();
        (0..samples)
            .map(|k| {
                let t = k as f64 * period;
                let command = scale
                    * tones
                        .iter()
                        .map(|(f, a, phi)| a * (core::f64::consts::TAU * f * t + phi).sin())
                        .sum::<f64>()
                    + trim_rate * t;
                let w = step(&mut rng);
                FlightSample {
                    command,
                    incidence: trim + w / v,
                }
            })
            .collect()
    }
}
