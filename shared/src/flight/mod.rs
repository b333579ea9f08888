//! Identification from windows of flight: one window's problem, load search and verdict
//! ([`window`]), the window read with the surface pinned to its sensor ([`pinned`]) and a
//! flight's reading fused from its windows ([`fusion`]). May import: the floors below
//! ([`crate::base`] … [`crate::preflight`]).

pub mod fusion;
pub mod pinned;
pub mod window;
