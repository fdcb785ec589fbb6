//! No code: this crate exists for its dependencies, which give every third-party crate of the
//! workspace one feature set whatever packages a cargo command selects (Cargo.toml says why).
