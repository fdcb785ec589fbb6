//! Position-dependent friction along the travel (being split by operation; the code is in
//! `iafv.rs` for now).

mod iafv;
mod lsq;
mod piecewise;
mod select;

pub use iafv::*;

#[cfg(test)]
mod tests;
