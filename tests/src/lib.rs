//! Shared helpers for handgate's cross-crate and interop tests.
