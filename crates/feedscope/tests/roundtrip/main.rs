//! Round trips through the digital twin: simulate a drive with known friction, estimate it,
//! compare with the truth; and condition histories built from it.
mod envelope;
mod estimate;
mod history;
mod ident;
mod map;
mod nc;
mod profile;
mod util;
mod verdict;
