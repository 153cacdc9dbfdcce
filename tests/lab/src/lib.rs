//! Cross-crate tests of the lab against the board; the tests are in `tests/`.
