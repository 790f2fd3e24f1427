//! Measuring renders: error against a reference.

pub mod metrics;
