//! End-to-end tests of the `feedscope` binary, each in a temporary directory.
mod dynamics;
mod estimate;
mod fit_stribeck;
mod simulate;
mod util;
