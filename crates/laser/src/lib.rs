#![doc = include_str!("../README.md")]
#![deny(missing_docs)]

mod correlative;
mod error;
pub mod frontend;
pub mod graph;
pub mod grid;
pub mod icp;
pub mod loops;
pub mod odometry;
pub mod pipeline;
pub mod scan;
pub mod sim;
pub mod sparse;
pub mod start;
pub mod wall_factor;
pub mod walls;

pub use error::{LaserError, Result};
pub use grid::MapIndex;
pub use icp::{IcpConfig, Match, Prior, match_scan};
pub use pipeline::{LaserConfig, LaserRun, ScanLog, run};
pub use scan::{Beams, ScanConfig, ScanPoints, scan_points};
pub use walls::WallConfig;
