// A build script makes cargo treat the crate's build-dependencies (proc-macro2, syn, cc…) as
// host dependencies to unify.
fn main() {}
