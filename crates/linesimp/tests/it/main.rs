//! The crate's integration tests as one binary, linked once: one binary per file
//! linked nalgebra, rand and the crate 35 times over the workspace, a large share
//! of `make test`'s build (issue 37).

mod common;
mod hull_equals_dp;
mod properties;
mod real_rings;
mod scale_and_overflow;
mod scan_edge_cases;
mod scan_room;
mod topology;
mod visvalingam;
mod walls;
