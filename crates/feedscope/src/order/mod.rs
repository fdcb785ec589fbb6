//! Spectra of the friction fluctuating signal (FFS) in screw orders and the drive's kinematic
//! orders (being split by operation; the code is in `fluctuation.rs` for now).

mod fluctuation;

pub use fluctuation::*;
