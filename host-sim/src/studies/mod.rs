//! Campaigns and studies over the reference model and the FDI.
//!
//! * [`campaign`] — accuracy campaigns over the paper's fault cases and the robustness grid.
//! * [`demagnetization`] — what today's FDI reads on demagnetized magnets (issue 35).
//! * [`domain`] — the survey behind the "outside the monitor model's domain" limits.
//! * [`grease`] — whether the chirp tells the grease's drag from its dry friction (issue 34).
//! * [`identifiability`] — which test design can tell every fault apart (sensitivity study).
//! * [`separability`] — whether one test tells two fault vectors apart at all.
//! * [`optimisers`] — the flown solver against other optimisers.
//! * [`stopping`] — choosing the GA's stop rule on the campaigns.
//! * [`prognostics`] — simulated degradations, trend and RUL reports and their evaluation.
//! * [`wind`] — the preflight on a parked surface in wind (issue 36).
//! * [`flight`] — today's FDI on windows of flight (issue 36).
//! * [`weak_magnet`] — one weak magnet against an eccentricity on the monitor model that
//!   carries the rotor's magnets (issue 69).
//! * [`physics`] — a family of nuisance physics for the reference model, drawn per seed
//!   (issue 68).

pub mod campaign;
pub mod demagnetization;
pub mod domain;
pub mod flight;
pub mod grease;
pub mod identifiability;
pub mod optimisers;
pub mod physics;
pub mod prognostics;
pub mod separability;
pub mod stopping;
pub mod weak_magnet;
pub mod wind;
