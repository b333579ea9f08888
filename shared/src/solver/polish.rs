//! The polish after the GA: damped Gauss–Newton (Levenberg–Marquardt) steps from the GA's best,
//! and from a few probe starts where the fitness has a known second basin, keeping the best
//! fitness found. Ask/tell like the GA: [`Polish::ask`] says what to compute next — the
//! Gauss–Newton sums at a vector (ten lockstep monitor-model runs,
//! [`crate::FitnessProblem::continue_curvature`], which the executor does in bounded chunks)
//! or the fitness of one candidate — and the `tell_*` calls hand back the result.
//!
//! Why probes: on the light actuator the GA stalls with the backlash at 0 and an eccentricity
//! standing in for it (Table II high 29 %, backlash 0.4 and 1.0: 7 and 19 %; `campaign
//! --runs-csv`: fitness 4.5× the truth's). The fitness is smooth inside a basin but the GA's
//! population collapses into the wrong one; a Gauss–Newton descent from the nominal vector with
//! the backlash set to a few levels lands in the right one in a handful of steps.
//!
//! Why a scan: a play's basin can be narrow. On the light actuator a backlash of 0.34 among
//! six other faults has its basin at 0.30–0.42 and a wide one at 0, a ridge between them at
//! 0.25; probes at fixed levels (0.25, 0.5, 1.0) start on the ridge or beyond the basin, and 2
//! of 10 runs read the play 0 at 12.6 % (`campaign --table random --actuator
//! actuators/light-28v.toml`). So the main leg's best is first evaluated with the component
//! on a grid (step `level` of its [`ProbeStart::ScanMinimum`] probes), and those probes start
//! at the grid's lowest local minima, best first, leaving out the main leg's own basin (a
//! minimum within one step of its level).
//!
//! Work: at most `iterations` + `probes · probe_iterations` + `iterations` Gauss–Newton sums
//! and as many fitness evaluations, plus one per probe start and one per scan level (at most
//! [`MAX_SCAN_LEVELS`]), fixed by [`PolishSettings`]; a rejected step reuses the sums with
//! more damping (one evaluation, no new sums). State: one [`Curvature`] (≈ 0.6 kB) and the
//! scan's fitnesses (128 B). Every step O(9³) besides what the executor computes.

use crate::physics::fault::FaultVector;
use crate::solver::uncertainty::Curvature;

/// Probe starts at most.
pub const MAX_PROBES: usize = 6;

/// Levels of the scan at most (its step at least `1 / MAX_SCAN_LEVELS`).
pub const MAX_SCAN_LEVELS: usize = 32;

/// Where a probe starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ProbeStart {
    /// The nominal vector with the component at `level`.
    Nominal,
    /// The main leg's best with the component at `level` (its other faults kept).
    Best,
    /// The main leg's best with the component at the scan's next lowest local minimum
    /// (`level`: the scan's step; skipped when the scan has no further minimum).
    ScanMinimum,
}

/// One probe start: component `component` moved as `start` says.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Probe {
    pub component: u8,
    pub level: f32,
    pub start: ProbeStart,
}

/// How much polishing; fixed per actuator.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PolishSettings {
    /// Gauss–Newton steps (accepted or not) from the GA's best, and again from a probe that
    /// beat it.
    pub iterations: u8,
    /// Steps from each probe start.
    pub probe_iterations: u8,
    pub probes: [Probe; MAX_PROBES],
    /// Probes used (the first `probe_count` of `probes`).
    pub probe_count: u8,
    /// Initial Levenberg–Marquardt damping (relative to the diagonal).
    pub damping: f32,
}

impl PolishSettings {
    /// The flown polish: 8 steps from the GA's best; the backlash scanned in steps of 0.05
    /// in the main leg's best, probes from its three lowest minima and with the backlash at
    /// 0.1, 0.5 and 1.0 in the nominal vector, 3 steps each.
    pub const FDI: Self = Self {
        iterations: 8,
        probe_iterations: 3,
        probes: [
            Probe::backlash(0.05, ProbeStart::ScanMinimum),
            Probe::backlash(0.05, ProbeStart::ScanMinimum),
            Probe::backlash(0.05, ProbeStart::ScanMinimum),
            Probe::backlash(0.1, ProbeStart::Nominal),
            Probe::backlash(0.5, ProbeStart::Nominal),
            Probe::backlash(1.0, ProbeStart::Nominal),
        ],
        probe_count: 6,
        damping: 1.0e-3,
    };

    /// No polish: the GA's best as it is.
    pub const NONE: Self = Self {
        iterations: 0,
        probe_iterations: 0,
        probes: [Probe::backlash(0.0, ProbeStart::Nominal); MAX_PROBES],
        probe_count: 0,
        damping: 1.0e-3,
    };

    /// Whether a polish can run these: at most 64 steps per leg, at most [`MAX_PROBES`]
    /// probes, a positive finite damping, each used probe a fault component (not the phase)
    /// at a level in [0, 1], the scan's probes one component and one step of at least
    /// `1 / MAX_SCAN_LEVELS`. O(probes).
    pub fn check(&self) -> bool {
        let used = || self.probes.iter().take(usize::from(self.probe_count));
        let probes_ok = used().all(|p| {
            usize::from(p.component) < crate::physics::fault::FAULT_COUNT
                && p.component != 6
                && (0.0..=1.0).contains(&p.level)
        });
        let scan_ok = match self.scan() {
            Some((component, step)) => {
                used()
                    .filter(|p| p.start == ProbeStart::ScanMinimum)
                    .all(|p| p.component == component && p.level == step)
                    && step >= 1.0 / MAX_SCAN_LEVELS as f32
            }
            None => true,
        };
        scan_ok
            && self.iterations <= 64
            && self.probe_iterations <= 64
            && usize::from(self.probe_count) <= MAX_PROBES
            && self.damping.is_finite()
            && self.damping > 0.0
            && probes_ok
    }

    /// Upper bound on the Gauss–Newton sums a polish computes.
    pub fn max_curvatures(&self) -> u32 {
        2 * u32::from(self.iterations)
            + u32::from(self.probe_count.min(MAX_PROBES as u8)) * u32::from(self.probe_iterations)
    }

    /// Upper bound on the fitness evaluations a polish does.
    pub fn max_evaluations(&self) -> u32 {
        self.max_curvatures()
            + u32::from(self.probe_count.min(MAX_PROBES as u8))
            + self.scan_levels() as u32
    }

    /// The scanned component and the scan's step: the first used
    /// [`ProbeStart::ScanMinimum`] probe's. O(probes).
    pub fn scan(&self) -> Option<(u8, f32)> {
        self.probes
            .iter()
            .take(usize::from(self.probe_count.min(MAX_PROBES as u8)))
            .find(|p| p.start == ProbeStart::ScanMinimum)
            .map(|p| (p.component, p.level))
    }

    /// The scan's levels: `step, 2·step, …` up to 1, at most [`MAX_SCAN_LEVELS`]; 0 without
    /// a scan. O(probes).
    pub fn scan_levels(&self) -> usize {
        match self.scan() {
            Some((_, step)) if step > 0.0 => {
                let n = 1.0 / step + 1.0e-3;
                if n >= MAX_SCAN_LEVELS as f32 {
                    MAX_SCAN_LEVELS
                } else {
                    n as usize
                }
            }
            _ => 0,
        }
    }
}

impl Probe {
    /// The backlash (component 2, index 1) at `level`, started as `start` says.
    pub const fn backlash(level: f32, start: ProbeStart) -> Self {
        Self {
            component: 1,
            level,
            start,
        }
    }
}

/// What the executor computes next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PolishAsk {
    /// The Gauss–Newton sums at this vector ([`Polish::tell_curvature`]).
    Curvature(FaultVector),
    /// The fitness of this vector; a value at or above `bound` is not used, so the
    /// evaluation may stop there ([`crate::FitnessProblem::error_below`]; then
    /// [`Polish::tell_fitness`]).
    Fitness { k: FaultVector, bound: f32 },
    /// Over: the best vector and its fitness.
    Done { k: FaultVector, fitness: f32 },
}

/// Which descent is running.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Leg {
    /// From the GA's best.
    Main,
    /// The main leg's best with the scanned component at level `j`.
    Scan(u8),
    /// From probe `i`.
    Probe(u8),
    /// From the probe that beat the main leg, with the main leg's steps.
    Final,
    Over,
}

/// Where the current descent stands.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Step {
    /// The start's fitness is wanted (a probe start or a scan level).
    StartFitness(FaultVector),
    /// The sums at `at` are wanted.
    Sums,
    /// The candidate from the sums is being evaluated.
    Candidate(FaultVector),
}

/// One polish in progress.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Polish {
    settings: PolishSettings,
    /// Best over every leg.
    best: (FaultVector, f32),
    /// The best when the main leg ended: the probes from it keep its other faults, and a
    /// probe that beats it earns the final leg.
    main: (FaultVector, f32),
    leg: Leg,
    step: Step,
    /// The current descent's point, its fitness, damping and steps taken.
    at: (FaultVector, f32),
    damping: f32,
    taken: u8,
    /// The sums at `at` (valid once `Sums` was told).
    sums: Curvature,
    /// The scan's fitness at each level (`+∞` until evaluated).
    scan: [f32; MAX_SCAN_LEVELS],
    /// The scan's minima handed to probes so far.
    scan_used: u8,
}

impl Polish {
    /// A polish of the GA's best `k` (fitness `fitness`).
    pub fn new(settings: PolishSettings, k: FaultVector, fitness: f32) -> Self {
        let mut p = Self {
            settings,
            best: (k, fitness),
            main: (k, fitness),
            leg: Leg::Main,
            step: Step::Sums,
            at: (k, fitness),
            damping: settings.damping,
            taken: 0,
            sums: Curvature::EMPTY,
            scan: [f32::INFINITY; MAX_SCAN_LEVELS],
            scan_used: 0,
        };
        p.settle();
        p
    }

    /// What to compute next. O(1).
    pub fn ask(&self) -> PolishAsk {
        match (self.leg, self.step) {
            (Leg::Over, _) => PolishAsk::Done {
                k: self.best.0,
                fitness: self.best.1,
            },
            (_, Step::StartFitness(k)) => PolishAsk::Fitness {
                k,
                bound: f32::INFINITY,
            },
            (_, Step::Sums) => PolishAsk::Curvature(self.at.0),
            (_, Step::Candidate(k)) => PolishAsk::Fitness {
                k,
                bound: self.at.1,
            },
        }
    }

    /// The Gauss–Newton sums at the asked vector. O(9³).
    pub fn tell_curvature(&mut self, sums: &Curvature) {
        if self.step == Step::Sums && self.leg != Leg::Over {
            self.sums = *sums;
            self.propose();
        }
    }

    /// The fitness of the asked vector (`+∞` or anything `≥` the bound: not better). O(9³).
    pub fn tell_fitness(&mut self, fitness: f32) {
        let fitness = if fitness.is_nan() {
            f32::INFINITY
        } else {
            fitness
        };
        match self.step {
            Step::StartFitness(k) => {
                if let Leg::Scan(j) = self.leg {
                    if let Some(slot) = self.scan.get_mut(usize::from(j)) {
                        *slot = fitness;
                    }
                }
                self.at = (k, fitness);
                self.keep(k, fitness);
                self.step = Step::Sums;
            }
            Step::Candidate(k) => {
                self.taken = self.taken.saturating_add(1);
                if fitness < self.at.1 {
                    self.at = (k, fitness);
                    self.keep(k, fitness);
                    self.damping = (self.damping / 3.0).max(1.0e-6);
                    self.step = Step::Sums;
                } else {
                    self.damping = (self.damping * 10.0).min(1.0e6);
                    // The sums at `at` still hold: a more damped step from them.
                    if self.taken < self.leg_steps() {
                        self.propose();
                        return;
                    }
                    self.step = Step::Sums;
                }
            }
            Step::Sums => return,
        }
        self.settle();
    }

    /// The best vector and fitness so far.
    pub fn best(&self) -> (FaultVector, f32) {
        self.best
    }

    fn keep(&mut self, k: FaultVector, fitness: f32) {
        if fitness < self.best.1 {
            self.best = (k, fitness);
        }
    }

    fn leg_steps(&self) -> u8 {
        match self.leg {
            Leg::Scan(_) => 0,
            Leg::Probe(_) => self.settings.probe_iterations,
            _ => self.settings.iterations,
        }
    }

    /// A candidate from the sums at `at`, or the leg's end when no component is determined.
    fn propose(&mut self) {
        match self
            .sums
            .gauss_newton_step(&self.at.0, f64::from(self.damping))
        {
            Some(k) if k != self.at.0 => self.step = Step::Candidate(k),
            _ => {
                self.taken = self.leg_steps();
                self.step = Step::Sums;
                self.settle();
            }
        }
    }

    /// Moves to the next leg while the current one has no steps left.
    fn settle(&mut self) {
        while self.leg != Leg::Over
            && self.taken >= self.leg_steps()
            && !matches!(self.step, Step::StartFitness(_) | Step::Candidate(_))
        {
            if self.leg == Leg::Main {
                self.main = self.best;
            }
            self.leg = match self.leg {
                Leg::Main => self.scan_leg(0),
                Leg::Scan(j) => self.scan_leg(j.saturating_add(1)),
                Leg::Probe(i) => self.probe_leg(i + 1),
                Leg::Final | Leg::Over => Leg::Over,
            };
            self.taken = 0;
            self.damping = self.settings.damping;
            match self.leg {
                Leg::Scan(j) => {
                    let start = self.scan_start(j);
                    self.step = Step::StartFitness(start);
                }
                Leg::Probe(i) => match self.probe_start(i) {
                    Some(start) => self.step = Step::StartFitness(start),
                    // No further minimum: the probe is skipped.
                    None => {
                        self.taken = self.leg_steps();
                        self.step = Step::Sums;
                    }
                },
                Leg::Final => {
                    self.at = self.best;
                    self.step = Step::Sums;
                }
                _ => {}
            }
        }
    }

    /// Probe `i` if there is one, else the final leg when a probe found a better basin than
    /// the main leg's end, else the end.
    fn probe_leg(&self, i: u8) -> Leg {
        if i < self.settings.probe_count.min(MAX_PROBES as u8) {
            Leg::Probe(i)
        } else if self.best.1 < self.main.1 && self.settings.iterations > 0 {
            Leg::Final
        } else {
            Leg::Over
        }
    }

    /// Scan level `j` if there is one, else the first probe.
    fn scan_leg(&self, j: u8) -> Leg {
        if usize::from(j) < self.settings.scan_levels() {
            Leg::Scan(j)
        } else {
            self.probe_leg(0)
        }
    }

    /// The level of scan step `j` (1-based multiples of the step, at most 1).
    fn scan_level(&self, j: usize) -> f32 {
        let step = self.settings.scan().map_or(1.0, |(_, step)| step);
        (step * (j + 1) as f32).min(1.0)
    }

    fn scan_start(&self, j: u8) -> FaultVector {
        let component = self.settings.scan().map_or(1, |(c, _)| c);
        let mut genes = *self.main.0.as_array();
        if let Some(g) = genes.get_mut(usize::from(component)) {
            *g = self.scan_level(usize::from(j));
        }
        FaultVector::saturating(genes)
    }

    /// The level of the scan's lowest local minimum not yet handed out, leaving out the main
    /// leg's own basin (within one step of its level). O(levels²).
    fn next_scan_minimum(&mut self) -> Option<f32> {
        let (component, step) = self.settings.scan()?;
        let n = self.settings.scan_levels();
        let own = self
            .main
            .0
            .as_array()
            .get(usize::from(component))
            .copied()?;
        let f = self.scan.get(..n)?;
        // Out of range reads as +∞: no level there, and no panic path on the flight core.
        let at = |j: usize| f.get(j).copied().unwrap_or(f32::INFINITY);
        let is_minimum = |j: usize| {
            let v = at(j);
            v.is_finite()
                && j.checked_sub(1).is_none_or(|k| v <= at(k))
                && v <= at(j + 1)
                && (self.scan_level(j) - own).abs() > step * 1.001
        };
        // The minima ordered by fitness (ties by level); the `scan_used`-th is next.
        let mut last: Option<(f32, usize)> = None;
        for _ in 0..=self.scan_used {
            let mut pick: Option<(f32, usize)> = None;
            for (j, &v) in f.iter().enumerate() {
                let after_last = last.is_none_or(|(lv, lj)| v > lv || (v == lv && j > lj));
                if is_minimum(j) && after_last && pick.is_none_or(|(pv, _)| v < pv) {
                    pick = Some((v, j));
                }
            }
            last = Some(pick?);
        }
        self.scan_used = self.scan_used.saturating_add(1);
        last.map(|(_, j)| self.scan_level(j))
    }

    fn probe_start(&mut self, i: u8) -> Option<FaultVector> {
        let probe = *self.settings.probes.get(usize::from(i))?;
        let (mut genes, level) = match probe.start {
            ProbeStart::Nominal => (*FaultVector::NOMINAL.as_array(), probe.level),
            ProbeStart::Best => (*self.main.0.as_array(), probe.level),
            ProbeStart::ScanMinimum => (*self.main.0.as_array(), self.next_scan_minimum()?),
        };
        if let Some(g) = genes.get_mut(usize::from(probe.component)) {
            *g = level;
        }
        Some(FaultVector::saturating(genes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::fault::FAULT_COUNT;

    /// |k − c|² over the components.
    fn squared_distance(k: &FaultVector, c: &[f32; FAULT_COUNT]) -> f32 {
        k.as_array()
            .iter()
            .zip(c)
            .map(|(x, y)| (x - y) * (x - y))
            .sum()
    }

    /// Two quadratic basins: `a` with a floor of `floor_a`, `b` at 0. Returns the fitness and
    /// the Gauss–Newton sums of the nearer basin at `k` (J = I, r = basin − k).
    fn basins(
        a: [f32; FAULT_COUNT],
        floor_a: f32,
        b: [f32; FAULT_COUNT],
    ) -> impl Fn(&FaultVector) -> (f32, Curvature) {
        move |k: &FaultVector| {
            let d = |c: &[f32; FAULT_COUNT]| squared_distance(k, c);
            let (fa, fb) = (d(&a) + floor_a, d(&b));
            let (f, centre) = if fa <= fb { (fa, a) } else { (fb, b) };
            let mut c = Curvature::EMPTY;
            for (i, (g, x)) in c.gradient.iter_mut().zip(k.as_array()).enumerate() {
                *g = f64::from(centre[i] - x);
                c.normal[i][i] = 1.0;
            }
            c.fitted = 1000;
            (f, c)
        }
    }

    /// Runs `polish` to its end against `problem`; the sums and fitnesses it asked for.
    fn drive(
        polish: &mut Polish,
        problem: &impl Fn(&FaultVector) -> (f32, Curvature),
    ) -> (u32, u32) {
        let (mut sums, mut fitnesses) = (0, 0);
        for _ in 0..1000 {
            match polish.ask() {
                PolishAsk::Curvature(k) => {
                    sums += 1;
                    polish.tell_curvature(&problem(&k).1);
                }
                PolishAsk::Fitness { k, .. } => {
                    fitnesses += 1;
                    polish.tell_fitness(problem(&k).0);
                }
                PolishAsk::Done { .. } => return (sums, fitnesses),
            }
        }
        panic!("the polish did not end");
    }

    #[test]
    fn a_quadratic_basin_is_reached_within_the_bound() {
        let target = [0.3, 0.0, 0.2, 0.0, 0.1, 0.0, 0.5, 0.6, 0.0];
        let problem = basins(target, 0.0, target);
        let start = FaultVector::NOMINAL;
        let mut polish = Polish::new(PolishSettings::FDI, start, problem(&start).0);
        let (sums, fitnesses) = drive(&mut polish, &problem);
        let (k, f) = polish.best();
        assert!(f < 1e-8, "{f} at {k:?}");
        for (x, t) in k.as_array().iter().zip(target) {
            assert!((x - t).abs() < 1e-3, "{k:?}");
        }
        assert!(sums <= PolishSettings::FDI.max_curvatures(), "{sums}");
        assert!(
            fitnesses <= PolishSettings::FDI.max_evaluations(),
            "{fitnesses}"
        );
    }

    #[test]
    fn a_probe_finds_the_backlash_basin_the_ga_missed() {
        // The GA's best sits in a basin with the backlash at 0 and an eccentricity instead;
        // the truth's basin has the backlash at 1.0.
        let wrong = [0.0, 0.0, 0.0, 0.0, 0.0, 0.25, 0.97, 0.5, 0.0];
        let right = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];
        let problem = basins(wrong, 0.05, right);
        let start = FaultVector::new(wrong).unwrap();
        let mut polish = Polish::new(PolishSettings::FDI, start, problem(&start).0);
        drive(&mut polish, &problem);
        let (k, f) = polish.best();
        assert!(
            f < 1e-6 && (k.as_array()[1] - 1.0).abs() < 1e-3,
            "{f} at {k:?}"
        );
        // Without probes it stays where the GA left it.
        let mut alone = Polish::new(
            PolishSettings {
                probe_count: 0,
                ..PolishSettings::FDI
            },
            start,
            problem(&start).0,
        );
        drive(&mut alone, &problem);
        assert!(alone.best().1 >= 0.05, "{:?}", alone.best());
    }

    /// A wide basin at `wide` with a floor and a narrow one (curvature `narrowness`) at
    /// `narrow`, each quadratic: the lower one's fitness and sums at `k`.
    fn wide_and_narrow(
        wide: [f32; FAULT_COUNT],
        floor: f32,
        narrow: [f32; FAULT_COUNT],
        narrowness: f32,
    ) -> impl Fn(&FaultVector) -> (f32, Curvature) {
        move |k: &FaultVector| {
            let d = |c: &[f32; FAULT_COUNT]| squared_distance(k, c);
            let (fw, fn_) = (d(&wide) + floor, narrowness * d(&narrow));
            let (f, centre, weight) = if fw <= fn_ {
                (fw, wide, 1.0)
            } else {
                (fn_, narrow, narrowness)
            };
            let mut c = Curvature::EMPTY;
            for (i, (g, x)) in c.gradient.iter_mut().zip(k.as_array()).enumerate() {
                *g = f64::from(weight * (centre[i] - x));
                c.normal[i][i] = f64::from(weight);
            }
            c.fitted = 1000;
            (f, c)
        }
    }

    #[test]
    fn the_scan_finds_a_narrow_play_basin_between_the_fixed_levels() {
        // The GA's best sits in a wide basin with the backlash at 0; the truth's basin is
        // narrow around 0.35, lower than the wide one only within ≈ 0.02 of it.
        let wide = [0.2, 0.0, 0.1, 0.0, 0.0, 0.1, 0.5, 0.5, 0.0];
        let mut narrow = wide;
        narrow[1] = 0.35;
        let problem = wide_and_narrow(wide, 0.05, narrow, 100.0);
        let start = FaultVector::new(wide).unwrap();
        let run = |settings: PolishSettings| {
            let mut polish = Polish::new(settings, start, problem(&start).0);
            let (sums, fitnesses) = drive(&mut polish, &problem);
            assert!(sums <= settings.max_curvatures(), "{sums}");
            assert!(fitnesses <= settings.max_evaluations(), "{fitnesses}");
            polish.best()
        };
        let (k, f) = run(PolishSettings::FDI);
        assert!(
            f < 1e-6 && (k.as_array()[1] - 0.35).abs() < 1e-3,
            "{f} at {k:?}"
        );
        // Probes at fixed levels from the same best (0.25, 0.5, 1.0) start in the wide basin.
        let mut fixed = PolishSettings::FDI;
        for (probe, level) in fixed.probes.iter_mut().zip([0.25, 0.5, 1.0]) {
            *probe = Probe::backlash(level, ProbeStart::Best);
        }
        assert!(run(fixed).1 >= 0.05, "{:?}", run(fixed));
    }

    #[test]
    fn the_scan_leaves_out_the_main_legs_own_basin() {
        // One basin only, at the GA's best: no scan minimum away from it, so the scan's
        // probes are skipped (no sums beyond the main leg's and the nominal probes').
        let target = [0.3, 0.4, 0.2, 0.0, 0.1, 0.0, 0.5, 0.6, 0.0];
        let problem = basins(target, 0.0, target);
        let start = FaultVector::new(target).unwrap();
        let mut polish = Polish::new(PolishSettings::FDI, start, problem(&start).0);
        let (sums, fitnesses) = drive(&mut polish, &problem);
        let s = PolishSettings::FDI;
        let scan = s.scan_levels() as u32;
        assert_eq!(scan, 20);
        // The main leg stops at once (no step improves the exact minimum); three nominal
        // probes with a start each.
        assert!(
            sums <= 1 + 3 * u32::from(s.probe_iterations),
            "{sums} sums, {fitnesses} fitnesses"
        );
        assert!(fitnesses >= scan + 3, "{fitnesses}");
        assert!(polish.best().1 < 1e-9);
    }

    #[test]
    fn a_record_refuses_a_scan_of_two_components() {
        let mut s = PolishSettings::FDI;
        assert!(s.check());
        s.probes[1].component = 5;
        assert!(!s.check());
        let mut t = PolishSettings::FDI;
        t.probes[0].level = 0.01;
        assert!(!t.check());
    }

    #[test]
    fn no_polish_hands_back_the_start() {
        let start = FaultVector::NOMINAL;
        let polish = Polish::new(PolishSettings::NONE, start, 0.5);
        assert_eq!(
            polish.ask(),
            PolishAsk::Done {
                k: start,
                fitness: 0.5
            }
        );
    }
}
