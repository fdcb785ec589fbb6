//! End-to-end tests of the `feedscope` binary, each in a temporary directory.
mod analyze;
mod dynamics;
mod estimate;
mod fit_stribeck;
mod identify;
mod map;
mod plan;
mod simulate;
mod util;
