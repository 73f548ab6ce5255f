//! Shared CLI conventions.
pub mod commands;
