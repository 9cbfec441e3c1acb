//! The crate's integration tests as one binary, linked once: one binary per file
//! linked nalgebra, rand and the crate 35 times over the workspace, a large share
//! of `make test`'s build (issue 37).

mod ekf;
mod monobot;
mod motion_real_data;
mod planar;
mod planar_compressed;
mod planar_control_bias;
mod planar_first_estimates;
mod planar_first_estimates_points;
mod planar_smooth;
mod planar_smooth_points;
mod planar_walls;
