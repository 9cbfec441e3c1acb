//! The extension module `rperc._rperc`.
//!
//! This crate only converts: numpy arrays in (with shape and dtype checks), numpy
//! arrays out (moved, not copied), and core-crate errors into Python exceptions. The
//! algorithms live in the core crates; the typed, documented API lives in the Python
//! package `rperc`.

mod arrays;
mod ceiling_py;
mod colour_shape_py;
mod config;
mod errors;
mod eval_py;
mod laser_py;
mod linesimp_py;
mod memory_py;
mod parallel;
mod pattern_py;
mod planar_py;
mod slam_py;
mod template_py;
mod text_py;
mod tracking_py;

use pyo3::prelude::*;

/// Native core of rperc. Use the `rperc` package, not this module directly.
#[pymodule]
mod _rperc {
    #[pymodule_export]
    use crate::ceiling_py::{PyCeilingWorld, ceiling_drive};
    #[pymodule_export]
    use crate::colour_shape_py::{PyColorShapeAnswer, PyColorShapeTracker, color_segment};
    #[pymodule_export]
    use crate::config::{config_check, config_defaults, config_names, config_schema};
    #[pymodule_export]
    use crate::errors::NumericalError;
    #[pymodule_export]
    use crate::errors::RpercError;
    #[pymodule_export]
    use crate::errors::check_allocation;
    #[pymodule_export]
    use crate::eval_py::{
        PyWorldWalls, otb_center_error, otb_groundtruth, otb_iou, otb_precision, otb_success_curve,
        pose_path_point, pose_transform_points, walls_to_world, wrap_angles,
    };
    #[pymodule_export]
    use crate::laser_py::{PyLaserRun, PyLaserScanPoints, laser_run, laser_scan_points};
    #[pymodule_export]
    use crate::linesimp_py::{
        PyScanWalls, extract_lines, simplify_indices, simplify_many_indices,
        simplify_topology_indices,
    };
    #[pymodule_export]
    use crate::memory_py::{
        PyMemoryFrames, PyMemoryLearning, PyMemoryReplay, visual_memory_check, visual_memory_learn,
        visual_memory_replay,
    };
    #[pymodule_export]
    use crate::pattern_py::{
        PyPatternAnswer, PyPatternSequence, PyPatternTracker, pattern_sequence,
    };
    #[pymodule_export]
    use crate::planar_py::{
        PyPlanarRun, PyPlanarStatistics, PySimulatedWorld, PySmoothedRun, planar_sim_check,
        planar_sim_nees, planar_sim_slam_config, planar_simulate, planar_slam_run, planar_smooth,
        wall_straightness_covariance,
    };
    #[pymodule_export]
    use crate::slam_py::{
        PyEkf, PyInformationSpectrum, PyKalmanUpdate, PyMonobotErrors, PyMonobotRun,
        PyMonobotSummary, information_spectrum, monobot_monte_carlo, monobot_observability_rank,
        monobot_simulate, monobot_summarize, nees_bounds,
    };
    #[pymodule_export]
    use crate::template_py::{PyColorTemplateAnswer, PyColorTemplateTracker};
    #[pymodule_export]
    use crate::text_py::{parse_floats, parse_line_floats, parse_lines_floats};
    #[pymodule_export]
    use crate::tracking_py::{
        PyColorHistogramTracker, PyParticleColorTracker, PyTrackAnswer, effective_sample_size,
        resample,
    };

    use super::*;

    #[pymodule_init]
    fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
        m.add("__version__", env!("CARGO_PKG_VERSION"))?;
        // The most particles any filter takes (rperc-core's bound), for Python's checks.
        m.add("MAX_PARTICLES", rperc_core::MAX_PARTICLES)?;
        crate::arrays::load_numpy_api(m.py())
    }
}
