//! One-test identification of the Stribeck friction and the total inertia (being split by
//! operation; the code is in `triangle.rs` for now).

mod triangle;

pub use triangle::*;

#[cfg(test)]
mod tests;
