//! Monte Carlo runs and the statistics the seed reports over them.

use rayon::prelude::*;

use super::model::{MeasurementModel, MonobotConfig};
use super::run::{MonobotRun, RunErrors, simulate_run};
use crate::error::{Result, SlamError};

/// `runs` independent runs on all cores. Run `i` draws from stream `i` of `seed`, so
/// the result does not depend on the number of threads.
pub fn monte_carlo(
    config: &MonobotConfig,
    model: MeasurementModel,
    runs: usize,
    seed: u64,
) -> Result<Vec<MonobotRun>> {
    if runs == 0 {
        return Err(SlamError::invalid("runs", "must be >= 1".into()));
    }
    // Refused before any run starts, naming runs: 10^9 of them ran on for minutes
    // (issue 38). A run keeps, per step, its errors (robot, NEES, each landmark) and
    // the estimate with its covariance's diagonal: a few floats per landmark.
    let per_step = 8 * (4 + 4 * config.landmarks as u128);
    rperc_core::check_allocation("runs", runs as u128, per_step * (config.steps as u128 + 1))?;
    // The pool's threads work under the caller's interrupt token (if any).
    let token = rperc_core::interrupt::current();
    (0..runs)
        .into_par_iter()
        .map(|i| {
            rperc_core::interrupt::run_with(token.clone(), || simulate_run(config, model, seed, i))
        })
        .collect()
}

/// Statistics over Monte Carlo runs, as the paper reports them.
#[derive(Debug, Clone, PartialEq)]
pub struct MonteCarloSummary {
    /// Number of runs.
    pub runs: usize,
    /// Run-averaged NEES of the whole state per step.
    pub nees: Vec<f64>,
    /// The 95 % (or requested) band for `nees`.
    pub nees_band: (f64, f64),
    /// Fraction of steps whose averaged NEES lies inside the band.
    pub nees_in_band: f64,
    /// Mean over runs (and landmarks) of the landmark error per step.
    pub landmark_error_mean: Vec<f64>,
    /// Standard deviation over runs (and landmarks) of the landmark error per step.
    pub landmark_error_std: Vec<f64>,
    /// Mean over runs of the robot error per step.
    pub robot_error_mean: Vec<f64>,
    /// Standard deviation over runs of the robot error per step.
    pub robot_error_std: Vec<f64>,
    /// Final (steady-state) landmark error of each run and landmark, `runs x landmarks`.
    pub final_landmark_error: Vec<f64>,
    /// Error right after initialisation, `runs x landmarks`.
    pub first_observation_error: Vec<f64>,
    /// Least-squares slope of the final error on the first-observation error: how
    /// much of the first observation's error the map keeps.
    pub sensitivity: f64,
    /// Correlation of final and first-observation errors.
    pub correlation: f64,
}

/// Summarises runs of one experiment (same config and model).
pub fn summarize(runs: &[RunErrors], confidence: f64) -> Result<MonteCarloSummary> {
    let Some(first) = runs.first() else {
        return Err(SlamError::invalid("runs", "need at least one run".into()));
    };
    let (n, len) = (first.landmarks, first.nees.len());
    if runs.iter().any(|r| {
        r.landmarks != n
            || r.nees.len() != len
            || r.robot_error.len() != len
            || r.landmark_error.len() != len * n
            || r.first_observation_error.len() != n
    }) {
        return Err(SlamError::dimension(
            "runs of different experiments cannot be summarised together".into(),
        ));
    }
    let per_step = PerStep::of(runs, n, len);
    let nees = per_step.nees;
    let band = rperc_core::nees_band(n + 1, runs.len(), confidence)?;
    let inside = nees.iter().filter(|&&v| v >= band.0 && v <= band.1).count();
    let final_err: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.landmark_error[(len - 1) * n..].iter().copied())
        .collect();
    let first_err: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.first_observation_error.iter().copied())
        .collect();
    let (slope, corr) = regression(&first_err, &final_err);
    Ok(MonteCarloSummary {
        runs: runs.len(),
        nees,
        nees_band: band,
        nees_in_band: inside as f64 / len as f64,
        landmark_error_mean: per_step.landmark_mean,
        landmark_error_std: per_step.landmark_std,
        robot_error_mean: per_step.robot_mean,
        robot_error_std: per_step.robot_std,
        final_landmark_error: final_err,
        first_observation_error: first_err,
        sensitivity: slope,
        correlation: corr,
    })
}

/// Per-step statistics over runs: mean NEES, and mean and standard deviation of the
/// landmark and robot errors.
struct PerStep {
    nees: Vec<f64>,
    landmark_mean: Vec<f64>,
    landmark_std: Vec<f64>,
    robot_mean: Vec<f64>,
    robot_std: Vec<f64>,
}

impl PerStep {
    fn of(runs: &[RunErrors], n: usize, len: usize) -> Self {
        let count = runs.len() as f64;
        let mut out = PerStep {
            nees: Vec::with_capacity(len),
            landmark_mean: Vec::with_capacity(len),
            landmark_std: Vec::with_capacity(len),
            robot_mean: Vec::with_capacity(len),
            robot_std: Vec::with_capacity(len),
        };
        for k in 0..len {
            out.nees
                .push(runs.iter().map(|r| r.nees[k]).sum::<f64>() / count);
            let (m, s) = mean_std(
                runs.iter()
                    .flat_map(|r| r.landmark_error[k * n..(k + 1) * n].iter().copied()),
            );
            out.landmark_mean.push(m);
            out.landmark_std.push(s);
            let (m, s) = mean_std(runs.iter().map(|r| r.robot_error[k]));
            out.robot_mean.push(m);
            out.robot_std.push(s);
        }
        out
    }
}

/// Mean and sample standard deviation.
fn mean_std(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut s, mut s2, mut c) = (0.0, 0.0, 0.0);
    for v in values {
        s += v;
        s2 += v * v;
        c += 1.0;
    }
    let mean = s / c;
    let var = (s2 / c - mean * mean).max(0.0) * c / (c - 1.0).max(1.0);
    (mean, var.sqrt())
}

/// Slope and correlation of the least-squares line of `y` on `x`.
fn regression(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for (&a, &b) in x.iter().zip(y) {
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
        sxy += (a - mx) * (b - my);
    }
    (sxy / sxx, sxy / (sxx * syy).sqrt())
}
