//! End-to-end tests of the `feedscope` binary, each in a temporary directory.
mod analyze;
mod dynamics;
mod edges;
mod estimate;
mod fit_stribeck;
mod glitch;
mod history;
mod identify;
mod import;
mod map;
mod parquet;
mod plan;
mod program;
mod real;
mod report;
mod simulate;
mod util;
