//! Subcommands of `rlg`; each is a thin wrapper over the library.

pub mod simulate;
