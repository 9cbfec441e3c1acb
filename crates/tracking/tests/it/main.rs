//! The crate's integration tests as one binary, linked once: one binary per file
//! linked nalgebra, rand and the crate 35 times over the workspace, a large share
//! of `make test`'s build (issue 37).

mod color_template;
mod colour;
mod condensation;
mod otb_parser;
mod pattern;
mod pattern_sequence;
mod pattern_tracker;
