//! Random numbers, per-pixel samplers and sampling warps.

pub mod pcg;
pub mod sampler;
pub mod warp;

pub use pcg::Pcg32;
pub use sampler::Sampler;
