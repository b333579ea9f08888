//! The weak-magnet search after the polish (issue 69): whether one weak magnet explains the
//! measured current better than the eccentricity the nine components read, and where it sits.
//!
//! A weak magnet is fixed to the rotor and dips each phase's coupling once per mechanical
//! revolution; an off-centre rotor's air gap is fixed to the stator. Both dip the current
//! once a revolution, so the GA, which has only the eccentricity's shape, reads a weak magnet
//! as an eccentricity. This search takes the polished vector with its eccentricity off and its
//! uniform loss lowered by the weak magnet's mean (`depth/(2P)` of the flux), and plays a weak
//! magnet ([`crate::magnets::WeakMagnet`]) in the monitor model:
//! 1. at [`CENTRES_PER_POLE`] centres per pole, each at depth [`CENTRE_DEPTH`];
//! 2. at the best centre, each of [`DEPTHS`].
//!
//! 3. when one of them explains the current better than the polished vector, the polish
//!    again from it with the magnet held (the problem's model plays it), then the depth moved
//!    by each of [`DEPTH_STEPS`] — first with the polished eccentricity and the rotor's mean
//!    flux kept ([`with_depth`]), then, where the polish read an eccentricity, each again
//!    with the vector built as the grid builds it ([`without_eccentricity`]: the
//!    eccentricity off, the uniform loss lowered by the moved magnet's mean) —, and the
//!    polish again from the best of them where it is better, at most [`MAX_POLISHES`]
//!    polishes in all. The moves run uncut: the last polish's first two with the polish's
//!    own fitness make the fitness's curvature along the depth
//!    ([`WeakMagnetSearch::depth_curvature`]), from which the uncertainty states the depth's
//!    deviation and verdict (`shared::uncertainty::depth_deviation`).
//!
//! Otherwise the polished vector stands and the magnets are read even. Ask/tell like the
//! polish: the executor sets the model's magnets and computes each fitness (one model run,
//! cut short at the bound), and runs each polish the search asks for.
//!
//! Why the moves built as the grid's: a polish holds the depth, so where the held depth is
//! short of the magnet's, the polish plays the rest as an eccentricity and a uniform loss
//! (each dips or lowers the coupling the magnet does). A move of the depth alone then adds
//! to what those already play and reads worse, and the search stopped short: on the light
//! actuator half a magnet at poles 0 and 7 read 0.40–0.45 with an eccentricity of
//! 0.025–0.056 and a uniform loss of 0.026–0.039 beside it, where the magnet of 0.5 alone
//! fits better. A move that takes them off hands the depth back; the polish after it plays
//! an eccentricity and a uniform loss again where the rotor has them. Only where the polish
//! read an eccentricity: run after every polish, the moves also took a uniform loss off in
//! the cold, where the model's mismatch prefers a shallower magnet (20 % at −60 K read 0.16
//! on either example actuator).
//!
//! Work: at most `min(2P, MAX_POLES)·CENTRES_PER_POLE + DEPTHS.len()` fitness evaluations
//! (42 for four pole pairs), then, only when a weak magnet is read, [`MAX_POLISHES`] polishes
//! and `2·MAX_POLISHES·DEPTH_STEPS.len()` evaluations (half of them only where a polish
//! read an eccentricity); O(1) besides them. State: a few dozen bytes.

use crate::magnets::{pole_pairs, poles, WeakMagnet};
use crate::physics::fault::{
    FaultVector, DEMAGNETIZATION_INDEX, DEMAGNETIZATION_LOSS_MAX, ECCENTRICITY_INDEX, FAULT_COUNT,
};
use crate::physics::params::ActuatorParams;
use crate::solver::polish::PolishSettings;

/// Candidate centres per pole pitch in the first pass.
pub const CENTRES_PER_POLE: u32 = 4;

/// The most poles the first pass visits (a rotor with more is searched over its first
/// `MAX_POLES` pitches only).
pub const MAX_POLES: u32 = 32;

/// The depth the first pass plays at every centre.
pub const CENTRE_DEPTH: f32 = 0.2;

/// The depths the second pass plays at the best centre (a share of the magnet's flux).
pub const DEPTHS: [f32; 10] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0];

/// The depth moves tried after each polish of a weak magnet's reading.
pub const DEPTH_STEPS: [f32; 4] = [-0.05, 0.05, -0.1, 0.1];

/// Depth moves after each polish: each of [`DEPTH_STEPS`] with the polished vector kept,
/// then, where the polish read an eccentricity, each built as the grid builds its vectors.
const MOVES: u32 = 2 * DEPTH_STEPS.len() as u32;

/// The finest step between two depths the search reads ([`DEPTHS`] and [`DEPTH_STEPS`]; the
/// polish holds the depth) [share of the magnet's flux].
pub const DEPTH_RESOLUTION: f32 = 0.05;

/// The most polishes a weak magnet's reading gets.
pub const MAX_POLISHES: u32 = 3;

/// What the search asks for next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MagnetAsk {
    /// The fitness of `k` with the model's magnets `magnets`; a value `≥ bound` may be
    /// returned as soon as the partial sum proves it.
    Fitness {
        k: FaultVector,
        magnets: WeakMagnet,
        bound: f32,
    },
    /// The polish from `start`, with the model playing `start.magnets`; its result goes to
    /// [`WeakMagnetSearch::tell_polished`].
    Polish(MagnetReading),
    /// Finished: the reading.
    Done(MagnetReading),
}

/// The search's reading: the vector (the polished one, or it with its eccentricity off and
/// its uniform loss lowered), the magnets and their fitness [A²·s].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagnetReading {
    pub faults: FaultVector,
    pub magnets: WeakMagnet,
    pub fitness: f32,
}

/// Where the search is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Candidate `i` of the centres, then of the depths.
    Grid(u32),
    /// The polish of the best reading.
    Polish,
    /// Depth move `i` from the polished reading `from`.
    Refine {
        i: u32,
        from: MagnetReading,
    },
    Done,
}

/// The search's state between asks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeakMagnetSearch {
    polished: MagnetReading,
    pole_pairs: f32,
    centres: u32,
    phase: Phase,
    polishes: u32,
    best_centre: (f32, f32),
    best: MagnetReading,
    /// The last polish's fitness and its first two depth moves' (move, fitness): the
    /// profile along the depth (NaN until measured).
    profile: (f32, [(f32, f32); 2]),
}

/// `k` with its eccentricity off and its uniform loss lowered by what a weak magnet of
/// `depth` takes on average, on a rotor of `pole_pairs` (clamped to [0, 1]). O(1).
pub fn without_eccentricity(k: &FaultVector, depth: f32, pole_pairs: f32) -> FaultVector {
    let mut a: [f32; FAULT_COUNT] = *k.as_array();
    if let Some(z) = a.get_mut(ECCENTRICITY_INDEX) {
        *z = 0.0;
    }
    // The polished vector's k9 is the rotor's whole mean loss: a magnet of depth 0.
    with_depth(&FaultVector::saturating(a), 0.0, depth, pole_pairs)
}

/// `k`, read with a weak magnet of depth `from`, moved to depth `to` with the rotor's mean
/// flux kept: its uniform loss rescaled (clamped to [0, 1]), every other component as it is.
/// O(1).
pub fn with_depth(k: &FaultVector, from: f32, to: f32, pole_pairs: f32) -> FaultVector {
    let mut a: [f32; FAULT_COUNT] = *k.as_array();
    if let Some(k9) = a.get_mut(DEMAGNETIZATION_INDEX) {
        let flux = 1.0 - DEMAGNETIZATION_LOSS_MAX * *k9;
        let kept_from = 1.0 - from / (2.0 * pole_pairs);
        let kept_to = 1.0 - to / (2.0 * pole_pairs);
        *k9 = (1.0 - flux * kept_from / kept_to) / DEMAGNETIZATION_LOSS_MAX;
    }
    FaultVector::saturating(a)
}

impl WeakMagnetSearch {
    /// A search from the polished vector `k` and its `fitness`, on the rotor of `params`.
    /// O(1).
    pub fn new(params: &ActuatorParams, k: FaultVector, fitness: f32) -> Self {
        let polished = MagnetReading {
            faults: k,
            magnets: WeakMagnet::NONE,
            fitness,
        };
        Self {
            polished,
            pole_pairs: pole_pairs(params),
            centres: poles(params).min(MAX_POLES) * CENTRES_PER_POLE,
            phase: Phase::Grid(0),
            polishes: 0,
            best_centre: (0.0, f32::INFINITY),
            best: polished,
            profile: (f32::NAN, [(f32::NAN, f32::NAN); 2]),
        }
    }

    /// Grid candidate `i`'s vector and magnets (`None` past the last). O(1).
    fn grid(&self, i: u32) -> Option<(FaultVector, WeakMagnet)> {
        let (depth, centre) = if i < self.centres {
            let pitch = core::f32::consts::PI / self.pole_pairs;
            let centre = pitch * i as f32 / CENTRES_PER_POLE as f32;
            (CENTRE_DEPTH, centre)
        } else {
            let j = (i - self.centres) as usize;
            (*DEPTHS.get(j)?, self.best_centre.0)
        };
        Some((
            without_eccentricity(&self.polished.faults, depth, self.pole_pairs),
            WeakMagnet::new(depth, centre),
        ))
    }

    /// Depth move `i` from `from`, or the first valid one after it: its index, vector and
    /// magnets (`None` past the last). Moves `DEPTH_STEPS.len()` and on build their vector as
    /// the grid does ([`without_eccentricity`] of `from`'s), and are valid only where `from`
    /// has an eccentricity. O(MOVES).
    fn refine(&self, i: u32, from: &MagnetReading) -> Option<(u32, FaultVector, WeakMagnet)> {
        let m = from.magnets;
        let steps = DEPTH_STEPS.len();
        let eccentric = from.faults.eccentricity() > 0.0;
        (i..MOVES).find_map(|j| {
            let alone = j as usize >= steps;
            let step = *DEPTH_STEPS.get(j as usize % steps)?;
            let depth = m.depth + step;
            (depth > 0.0 && depth <= 1.0 && (eccentric || !alone)).then(|| {
                let k = if alone {
                    without_eccentricity(&from.faults, depth, self.pole_pairs)
                } else {
                    with_depth(&from.faults, m.depth, depth, self.pole_pairs)
                };
                (j, k, WeakMagnet::new(depth, m.centre))
            })
        })
    }

    /// What to compute next. O(MOVES).
    pub fn ask(&self) -> MagnetAsk {
        match self.phase {
            Phase::Grid(i) => match self.grid(i) {
                Some((k, magnets)) => MagnetAsk::Fitness {
                    k,
                    magnets,
                    bound: if i < self.centres {
                        self.best_centre.1
                    } else {
                        self.best.fitness
                    },
                },
                // `tell` moves on past the grid's last candidate.
                None => MagnetAsk::Done(self.best),
            },
            Phase::Polish => MagnetAsk::Polish(self.best),
            // Uncut: the profile needs the moves' fitness (a cut one is still at or above
            // the best, so no choice moves).
            Phase::Refine { i, from } => match self.refine(i, &from) {
                Some((_, k, magnets)) => MagnetAsk::Fitness {
                    k,
                    magnets,
                    bound: f32::INFINITY,
                },
                None => MagnetAsk::Done(self.best),
            },
            Phase::Done => MagnetAsk::Done(self.best),
        }
    }

    /// Hands back the fitness of the last [`MagnetAsk::Fitness`]. O(MOVES); ignored
    /// otherwise.
    pub fn tell(&mut self, fitness: f32) {
        match self.phase {
            Phase::Grid(i) => {
                let Some((k, magnets)) = self.grid(i) else {
                    return;
                };
                if i < self.centres {
                    if fitness < self.best_centre.1 {
                        self.best_centre = (magnets.centre, fitness);
                    }
                } else if fitness < self.best.fitness {
                    self.best = MagnetReading {
                        faults: k,
                        magnets,
                        fitness,
                    };
                }
                self.phase = if self.grid(i + 1).is_some() {
                    Phase::Grid(i + 1)
                } else if self.best.magnets.is_none() {
                    Phase::Done
                } else {
                    Phase::Polish
                };
            }
            Phase::Refine { i, from } => {
                let Some((j, k, magnets)) = self.refine(i, &from) else {
                    return;
                };
                let step = magnets.depth - from.magnets.depth;
                if let Some(slot) = self.profile.1.iter_mut().find(|(s, _)| s.is_nan()) {
                    *slot = (step, fitness);
                }
                if fitness < self.best.fitness {
                    self.best = MagnetReading {
                        faults: k,
                        magnets,
                        fitness,
                    };
                }
                self.phase = if self.refine(j + 1, &from).is_some() {
                    Phase::Refine { i: j + 1, from }
                } else {
                    self.after_refining(&from)
                };
            }
            Phase::Polish | Phase::Done => {}
        }
    }

    /// Hands back the polish of the last [`MagnetAsk::Polish`]: its reading, whose fitness is
    /// never above the start's. O(MOVES); ignored otherwise.
    pub fn tell_polished(&mut self, polished: MagnetReading) {
        if self.phase != Phase::Polish {
            return;
        }
        self.polishes += 1;
        if polished.fitness <= self.best.fitness {
            self.best = polished;
        }
        let from = self.best;
        self.profile = (from.fitness, [(f32::NAN, f32::NAN); 2]);
        self.phase = match self.refine(0, &from) {
            Some((i, ..)) => Phase::Refine { i, from },
            None => Phase::Done,
        };
    }

    /// After the depth moves from `from`: polish a better one while polishes remain.
    fn after_refining(&self, from: &MagnetReading) -> Phase {
        if self.best.fitness < from.fitness && self.polishes < MAX_POLISHES {
            Phase::Polish
        } else {
            Phase::Done
        }
    }

    /// The curvature of the fitness along the read magnet's depth, the rotor's mean flux
    /// kept [A²·s per unit of depth²]: the second difference through the last polish's
    /// reading and its first two depth moves (either side of it, or both on one side at the
    /// depth's ends), at or within a move of the reading. 0 when no magnet is read or the
    /// difference is not a number (no deviation follows from it; 0, not NaN, so that two
    /// equal readings compare equal). O(1).
    pub fn depth_curvature(&self) -> f32 {
        let (f0, [(a, fa), (b, fb)]) = self.profile;
        let c = 2.0 * ((fa - f0) / a - (fb - f0) / b) / (a - b);
        if c.is_finite() {
            c
        } else {
            0.0
        }
    }

    /// The most fitness evaluations this search asks for, beside its polishes.
    pub fn max_evaluations(&self) -> u32 {
        self.centres + DEPTHS.len() as u32 + MAX_POLISHES * MOVES
    }

    /// The most work after the GA on the rotor of `params` with polishes `polish`: the
    /// polish, this search and its polishes, as (fitness evaluations, Gauss–Newton sums).
    pub fn work_after_ga(params: &ActuatorParams, polish: &PolishSettings) -> (u32, u32) {
        let search = Self::new(params, FaultVector::NOMINAL, 0.0).max_evaluations();
        let polishes = 1 + MAX_POLISHES;
        (
            polish
                .max_evaluations()
                .saturating_mul(polishes)
                .saturating_add(search),
            polish.max_curvatures().saturating_mul(polishes),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::magnets::pole_pitch;

    /// A made-up fitness: lowest for a magnet of depth 0.33 centred at pole 5 with no
    /// eccentricity.
    fn fitness(k: &FaultVector, m: &WeakMagnet, params: &ActuatorParams) -> f32 {
        let pitch = pole_pitch(params);
        let dc = m.centre - 5.0 * pitch;
        let e = k.as_array()[ECCENTRICITY_INDEX];
        if m.is_none() {
            return 1.0 + e;
        }
        0.5 + dc * dc + (m.depth - 0.33) * (m.depth - 0.33) + e
    }

    /// Runs `search` against [`fitness`], each polish handing its start back unchanged:
    /// the reading, the fitness evaluations and the polishes.
    fn run(search: &mut WeakMagnetSearch, params: &ActuatorParams) -> (MagnetReading, u32, u32) {
        let (mut n, mut polishes) = (0, 0);
        loop {
            match search.ask() {
                MagnetAsk::Fitness { k, magnets, .. } => {
                    n += 1;
                    search.tell(fitness(&k, &magnets, params));
                }
                MagnetAsk::Polish(start) => {
                    polishes += 1;
                    search.tell_polished(start);
                }
                MagnetAsk::Done(r) => return (r, n, polishes),
            }
        }
    }

    #[test]
    fn finds_the_centre_then_the_depth_then_moves_the_depth_after_each_polish() {
        let p = ActuatorParams::default();
        let k = FaultVector::new([0.0, 0.0, 0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.1]).unwrap();
        let mut search = WeakMagnetSearch::new(&p, k, 1.2);
        let (r, n, polishes) = run(&mut search, &p);
        assert!(n <= search.max_evaluations());
        // The grid (8 poles × 4 centres, 10 depths) reads 0.3; a polish; the move to 0.35
        // is better; a polish; no move from 0.35 is better (0.3, 0.4, 0.25, 0.45). No
        // polish reads an eccentricity, so no move runs a second time.
        assert_eq!(n, 8 * CENTRES_PER_POLE + DEPTHS.len() as u32 + 4 + 4);
        assert_eq!(polishes, 2);
        // Through 0.30, 0.35 and 0.40: the made-up fitness's second derivative along the
        // depth, 2.
        let c = search.depth_curvature();
        assert!((c - 2.0).abs() < 1e-3, "{c}");
        assert_eq!(r.magnets.pole(&p), 5);
        assert!((r.magnets.depth - 0.35).abs() < 1e-6, "{}", r.magnets.depth);
        assert_eq!(r.faults.as_array()[ECCENTRICITY_INDEX], 0.0);
        // The uniform loss: 0.05 of the flux, less the magnet's mean 0.35/8.
        let k9 = r.faults.as_array()[DEMAGNETIZATION_INDEX];
        let expected = (1.0 - 0.95 / (1.0 - 0.35 / 8.0)) / DEMAGNETIZATION_LOSS_MAX;
        assert!((k9 - expected).abs() < 1e-5, "{k9} against {expected}");
    }

    #[test]
    fn a_depth_the_polish_left_to_an_eccentricity_is_handed_back() {
        // Made-up: a magnet of 0.5 at the grid's pole; an eccentricity e plays some of its
        // depth (the residual 0.5 − depth − e, with e² a quarter as costly) and the friction's
        // error moves the residual too. From friction 0 the grid reads 0.4; the polish
        // (friction to 0.1, the eccentricity to its best at the held depth) reads e = 0.08.
        let p = ActuatorParams::default();
        let pitch = pole_pitch(&p);
        let f = |k: &FaultVector, m: &WeakMagnet| {
            let a = k.as_array();
            let (fr, e) = (a[0], a[ECCENTRICITY_INDEX]);
            if m.is_none() {
                return 1.0;
            }
            let r = 0.5 - m.depth - e + (fr - 0.1);
            let dc = m.centre - 2.0 * pitch;
            r * r + 0.25 * e * e + (fr - 0.1) * (fr - 0.1) + dc * dc
        };
        let k = FaultVector::new([0.0, 0.0, 0.0, 0.0, 0.0, 0.3, 0.5, 0.5, 0.1]).unwrap();
        let mut search = WeakMagnetSearch::new(&p, k, 1.0);
        let (mut n, mut depths) = (0, Vec::new());
        let r = loop {
            match search.ask() {
                MagnetAsk::Fitness { k, magnets, .. } => {
                    n += 1;
                    search.tell(f(&k, &magnets));
                }
                MagnetAsk::Polish(start) => {
                    depths.push(start.magnets.depth);
                    let mut a = *start.faults.as_array();
                    a[0] = 0.1;
                    a[ECCENTRICITY_INDEX] = ((0.5 - start.magnets.depth) / 1.25).max(0.0);
                    let faults = FaultVector::new(a).unwrap();
                    search.tell_polished(MagnetReading {
                        faults,
                        magnets: start.magnets,
                        fitness: f(&faults, &start.magnets),
                    });
                }
                MagnetAsk::Done(r) => break r,
            }
        };
        assert!(n <= search.max_evaluations());
        // Polished at 0.4 (e = 0.08: every move of the depth alone reads worse), then at
        // 0.5 from the move with the eccentricity off.
        assert_eq!(depths.len(), 2, "{depths:?}");
        assert!((depths[0] - 0.4).abs() < 1e-6, "{depths:?}");
        assert!((r.magnets.depth - 0.5).abs() < 1e-6, "{}", r.magnets.depth);
        assert_eq!(r.faults.as_array()[ECCENTRICITY_INDEX], 0.0);
        assert!(r.fitness < 1e-9, "{}", r.fitness);
    }

    #[test]
    fn a_whole_magnets_profile_lies_below_it() {
        // Lowest past a whole magnet (3·(depth − 1.2)²): the grid reads 1.0, no move from it
        // is better, and its profile runs through the moves down (0.95, 0.9).
        let p = ActuatorParams::default();
        let k = FaultVector::new([0.0, 0.0, 0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.3]).unwrap();
        let mut search = WeakMagnetSearch::new(&p, k, 10.0);
        let f = |m: &WeakMagnet| 3.0 * (m.depth - 1.2) * (m.depth - 1.2);
        let r = loop {
            match search.ask() {
                MagnetAsk::Fitness { magnets, bound, .. } => {
                    // A depth move runs uncut.
                    if search.polishes > 0 {
                        assert_eq!(bound, f32::INFINITY);
                    }
                    search.tell(f(&magnets));
                }
                MagnetAsk::Polish(start) => search.tell_polished(start),
                MagnetAsk::Done(r) => break r,
            }
        };
        assert_eq!(search.polishes, 1);
        assert_eq!(r.magnets.depth, 1.0);
        let c = search.depth_curvature();
        assert!((c - 6.0).abs() < 1e-2, "{c}");
    }

    #[test]
    fn no_magnet_no_curvature() {
        let p = ActuatorParams::default();
        let k = FaultVector::new([0.1, 0.0, 0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.0]).unwrap();
        let mut search = WeakMagnetSearch::new(&p, k, 0.4);
        while let MagnetAsk::Fitness { .. } = search.ask() {
            search.tell(1.0);
        }
        assert_eq!(search.depth_curvature(), 0.0);
    }

    #[test]
    fn keeps_the_polished_vector_when_no_magnet_does_better() {
        let p = ActuatorParams::default();
        let k = FaultVector::new([0.1, 0.0, 0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.0]).unwrap();
        let mut search = WeakMagnetSearch::new(&p, k, 0.4);
        let (r, n, polishes) = run(&mut search, &p);
        assert!(r.magnets.is_none());
        assert_eq!(r.faults, k);
        assert_eq!(r.fitness, 0.4);
        assert_eq!(
            (n, polishes),
            (8 * CENTRES_PER_POLE + DEPTHS.len() as u32, 0)
        );
    }

    #[test]
    fn polishes_stop_at_their_bound() {
        // Fitness (depth − 0.33)² + friction; each polish takes 0.1 off the friction but
        // moves the depth 0.1 down, so a depth move after it is always better: only
        // MAX_POLISHES stops the search.
        let p = ActuatorParams::default();
        let f = |k: &FaultVector, m: &WeakMagnet| (m.depth - 0.33).powi(2) + k.as_array()[0];
        let k = FaultVector::new([0.5, 0.0, 0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.0]).unwrap();
        let mut search = WeakMagnetSearch::new(&p, k, 10.0);
        let mut polishes = 0;
        loop {
            match search.ask() {
                MagnetAsk::Fitness { k, magnets, .. } => search.tell(f(&k, &magnets)),
                MagnetAsk::Polish(start) => {
                    polishes += 1;
                    let mut a = *start.faults.as_array();
                    a[0] -= 0.1;
                    let faults = FaultVector::new(a).unwrap();
                    let magnets = WeakMagnet::new(start.magnets.depth - 0.1, start.magnets.centre);
                    search.tell_polished(MagnetReading {
                        faults,
                        magnets,
                        fitness: f(&faults, &magnets),
                    });
                }
                MagnetAsk::Done(r) => {
                    assert_eq!(polishes, MAX_POLISHES);
                    assert!((r.magnets.depth - 0.3).abs() < 1e-6, "{}", r.magnets.depth);
                    assert!((r.faults.as_array()[0] - 0.2).abs() < 1e-6);
                    break;
                }
            }
        }
    }

    #[test]
    fn a_uniform_loss_below_the_magnets_mean_reads_none() {
        let k = FaultVector::new([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]).unwrap();
        let out = without_eccentricity(&k, 1.0, 4.0);
        assert_eq!(out.as_array()[DEMAGNETIZATION_INDEX], 0.0);
    }

    #[test]
    fn a_depth_move_keeps_the_rotors_mean_flux() {
        let k = FaultVector::new([0.0, 0.0, 0.0, 0.0, 0.0, 0.1, 0.5, 0.5, 0.2]).unwrap();
        let moved = with_depth(&k, 0.3, 0.5, 4.0);
        let flux = |k: &FaultVector, d: f32| {
            (1.0 - DEMAGNETIZATION_LOSS_MAX * k.as_array()[DEMAGNETIZATION_INDEX]) * (1.0 - d / 8.0)
        };
        assert!((flux(&k, 0.3) - flux(&moved, 0.5)).abs() < 1e-6);
        assert_eq!(moved.as_array()[ECCENTRICITY_INDEX], 0.1);
    }
}
