//! The monobot study of seed 000, section 2.2: a 1-D robot among static landmarks,
//! eqs. (14) to (23), Figures 3 to 6.
//!
//! Plant (eq. 19): `x_{k+1} = x_k + u_k + v_k`. Three measurement models:
//! - [`MeasurementModel::Relative`]: `z_i = l_i - x + w_i`, `H = [-1, I]` (eq. 2 with
//!   the fully correlated Jacobian): the Fisher information is singular;
//! - [`MeasurementModel::Anchor`]: a landmark at the origin serves as a global
//!   reference, `z_0 = -x + w_0` (eq. 20);
//! - [`MeasurementModel::External`]: a fixed sensor measures the robot, `z_0 = x + w_0`
//!   (eq. 23).

mod model;
mod monte_carlo;
mod observability;
mod run;

pub use model::{MeasurementModel, MonobotConfig, Noise, NoiseKind, USABLE_VARIANCE};
pub use monte_carlo::{MonteCarloSummary, monte_carlo, summarize};
pub use observability::{
    InformationSpectrum, information_spectrum, observability_matrix, observability_rank,
    one_landmark_fisher, rank, unobservable_directions,
};
pub use run::{MonobotRun, RunErrors, simulate, simulate_run};
