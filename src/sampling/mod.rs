//! Random numbers, sample sequences, and the warps that turn them into points and directions.

pub mod alias;
pub mod distribution;
pub mod prefetch;
pub mod rng;
pub mod sampler;
pub mod warp;
#[cfg(target_arch = "x86_64")]
mod warp_avx2;
