//! The TRaX baseline chip (issue 8): configuration and the ray program so far.

pub mod config;
pub mod isa;
pub mod program;

pub use config::{TraxConfig, UnitConfig};
pub use program::{Program, Run, Seg};
