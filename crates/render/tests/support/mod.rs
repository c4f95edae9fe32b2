//! Helpers shared by the render core's integration tests: χ² tests of samplers against their
//! densities ([`chi2`]), random scenes ([`scenes`]) and the radiosity tests' scenes and image
//! helpers ([`radiosity`]). Every test file declares `mod support;` and uses what it needs.
#![allow(dead_code)]

pub mod chi2;
pub mod radiosity;
pub mod scenes;
