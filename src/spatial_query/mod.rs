//! Spatial queries.

pub mod exact;
