//! `rlg`: the command-line front end of `host-trainer`.
fn main() {}
