//! Test-only crate: see `tests/`. Shared helpers for the cross-crate tests go here.

#![warn(missing_docs)]
