//! The crate's integration tests as one binary, linked once: one binary per file
//! linked nalgebra, rand and the crate 35 times over the workspace, a large share
//! of `make test`'s build (issue 37).

mod graph;
mod icp;
mod pipeline;
mod sparse;
mod walls;
