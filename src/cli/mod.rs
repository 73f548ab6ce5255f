//! Shared CLI conventions.
