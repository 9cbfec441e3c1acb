#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

pub mod ceiling;
mod error;
pub mod memory;

pub use error::{NavigationError, Result};
