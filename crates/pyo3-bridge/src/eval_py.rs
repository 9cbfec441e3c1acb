//! Bindings of the evaluation pieces Python must not re-derive: OTB ground truth, the
//! OTB metrics, and SE(2) point transforms (rperc-core's `Pose2`).

use nalgebra::{Point2, Vector2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayDyn};
use pyo3::prelude::*;
use rperc_core::Pose2;
use slam::wall::wall_to_world;
use tracking::BoundingBox;

use crate::arrays::{float_vector, frozen_array, point_rows};
use crate::errors::Error;

/// Boxes of an `(N, 4)` array named `name`.
fn boxes(obj: &Bound<'_, PyAny>, name: &str) -> Result<Vec<BoundingBox>, Error> {
    let (shape, data) = crate::arrays::tensor(obj, name, 2)?;
    if shape[1] != 4 {
        return Err(Error::Value(format!(
            "{name} must have shape (N, 4) as x, y, w, h; got {shape:?}"
        )));
    }
    Ok(data
        .chunks_exact(4)
        .map(|b| BoundingBox::new(b[0], b[1], b[2], b[3]))
        .collect())
}

/// Two box arrays of the same length.
fn box_pairs(
    a: &Bound<'_, PyAny>,
    b: &Bound<'_, PyAny>,
) -> Result<(Vec<BoundingBox>, Vec<BoundingBox>), Error> {
    let (a, b) = (boxes(a, "a")?, boxes(b, "b")?);
    if a.len() != b.len() {
        return Err(Error::Value(format!(
            "a and b must hold as many boxes, got {} and {}",
            a.len(),
            b.len()
        )));
    }
    Ok((a, b))
}

/// `metric` of matching rows of two `(N, 4)` box arrays.
fn pairwise<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
    metric: fn(&BoundingBox, &BoundingBox) -> f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (a, b) = box_pairs(a, b)?;
    let out: Vec<f64> = a.iter().zip(&b).map(|(x, y)| metric(x, y)).collect();
    Ok(out.into_pyarray(py))
}

/// A `#[pyfunction]` `name(a, b)` giving [`pairwise`] `metric` of two box arrays: the
/// OTB metrics differ only in the metric.
macro_rules! box_metric {
    ($(#[$doc:meta])* $name:ident => $metric:path) => {
        $(#[$doc])*
        #[pyfunction]
        pub fn $name<'py>(
            py: Python<'py>,
            a: &Bound<'py, PyAny>,
            b: &Bound<'py, PyAny>,
        ) -> PyResult<Bound<'py, PyArray1<f64>>> {
            pairwise(py, a, b, $metric)
        }
    };
}

box_metric!(
    /// IoU of matching rows of two `(N, 4)` box arrays.
    otb_iou => tracking::metrics::iou
);
box_metric!(
    /// Centre distances of matching rows of two `(N, 4)` box arrays.
    otb_center_error => tracking::metrics::centre_error
);

/// The success curve over the 21 OTB thresholds.
#[pyfunction]
pub fn otb_success_curve<'py>(
    py: Python<'py>,
    overlaps: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let o = float_vector(overlaps, "overlaps")?;
    Ok(tracking::metrics::success_curve(&o)
        .to_vec()
        .into_pyarray(py))
}

/// Fraction of centre errors at most `threshold` pixels.
#[pyfunction]
pub fn otb_precision(errors: &Bound<'_, PyAny>, threshold: f64) -> PyResult<f64> {
    let e = float_vector(errors, "errors")?;
    Ok(tracking::metrics::precision(&e, threshold))
}

/// Ground-truth boxes of an OTB file's text, with 0-based corners; `name` labels errors.
#[pyfunction]
pub fn otb_groundtruth<'py>(
    py: Python<'py>,
    text: &str,
    name: &str,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let boxes = tracking::otb::parse_groundtruth(text, name).map_err(Error::from)?;
    let flat: Vec<f64> = boxes.iter().flat_map(|b| b.to_array()).collect();
    let n = boxes.len();
    Ok(numpy::ndarray::Array2::from_shape_vec((n, 4), flat)
        .map_err(|e| Error::Value(e.to_string()))?
        .into_pyarray(py))
}

/// Angles `(N,)` wrapped into (-pi, pi] by rperc-core's `wrap_angle` (NaN for a
/// non-finite angle): the one wrap of the project.
#[pyfunction]
pub fn wrap_angles<'py>(
    py: Python<'py>,
    angles: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let mut a = float_vector(angles, "angles")?;
    for v in a.iter_mut() {
        *v = rperc_core::wrap_angle(*v);
    }
    Ok(a.into_pyarray(py))
}

/// The world lines of sensor-frame walls `(rho, alpha)` (both `(K,)`) seen from
/// `pose = (x, y, theta)`, by rperc-slam's `wall_to_world` (the one place of that
/// model): `rho_w (K,)`, `alpha_w (K,)`, `d/d(rho, alpha) (K, 2, 2)` and
/// `d/d pose (K, 2, 3)`.
#[pyfunction]
pub fn walls_to_world<'py>(
    py: Python<'py>,
    rho: &Bound<'py, PyAny>,
    alpha: &Bound<'py, PyAny>,
    pose: &Bound<'py, PyAny>,
) -> PyResult<PyWorldWalls> {
    let (rho, alpha) = (float_vector(rho, "rho")?, float_vector(alpha, "alpha")?);
    if rho.len() != alpha.len() {
        return Err(Error::Value(format!(
            "rho and alpha must have the same length, got {} and {}",
            rho.len(),
            alpha.len()
        ))
        .into());
    }
    let robot = pose3(pose)?;
    let k = rho.len();
    let (mut rw, mut aw) = (Vec::with_capacity(k), Vec::with_capacity(k));
    let (mut jw, mut jp) = (Vec::with_capacity(4 * k), Vec::with_capacity(6 * k));
    for (r, a) in rho.iter().zip(&alpha) {
        let j = wall_to_world(&robot, &Vector2::new(*r, *a))
            .ok_or_else(|| Error::Value(format!("walls must be finite, got rho {r}, alpha {a}")))?;
        rw.push(j.wall.x);
        aw.push(j.wall.y);
        // nalgebra is column-major; numpy wants the rows in order.
        jw.extend(j.d_wall.transpose().iter());
        jp.extend(j.d_pose.transpose().iter());
    }
    Ok(PyWorldWalls {
        rho: frozen_array(py, rw, &[k])?,
        alpha: frozen_array(py, aw, &[k])?,
        d_wall: frozen_array(py, jw, &[k, 2, 2])?,
        d_pose: frozen_array(py, jp, &[k, 2, 3])?,
    })
}

/// The world path `(N, 2)` of one point `offset` of the robot (its frame: forward,
/// left) over the poses `(N, 3)`: `R(theta_k) offset + (x_k, y_k)` for each pose, by
/// rperc-core's `Pose2` (a GPS antenna or laser on a lever arm).
#[pyfunction]
pub fn pose_path_point<'py>(
    py: Python<'py>,
    poses: &Bound<'py, PyAny>,
    offset: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let rows = crate::planar_py::rows::<3>(Some(poses), "poses")?;
    let offset = match float_vector(offset, "offset")?[..] {
        [fx, fy] if fx.is_finite() && fy.is_finite() => Point2::new(fx, fy),
        ref o => {
            return Err(Error::Value(format!(
                "offset must be 2 finite numbers (forward, left), got {o:?}"
            ))
            .into());
        }
    };
    let mut path = Vec::with_capacity(2 * rows.len());
    for (k, &[x, y, theta]) in rows.iter().enumerate() {
        if !(x.is_finite() && y.is_finite() && theta.is_finite()) {
            return Err(Error::Value(format!(
                "poses must be finite, row {k} is ({x}, {y}, {theta})"
            ))
            .into());
        }
        let q = Pose2 { x, y, theta }.transform_point(&offset);
        path.extend([q.x, q.y]);
    }
    Ok(
        numpy::ndarray::Array2::from_shape_vec((rows.len(), 2), path)
            .map_err(|e| Error::Value(e.to_string()))?
            .into_pyarray(py),
    )
}

/// Walls moved to the world by [`walls_to_world`], frozen, arrays read-only: `rho`
/// and `alpha` (K) and the Jacobians `d_wall` (K, 2, 2) and `d_pose` (K, 2, 3).
#[pyclass(name = "WorldWalls", module = "rperc._rperc", frozen, get_all)]
pub struct PyWorldWalls {
    rho: Py<PyArrayDyn<f64>>,
    alpha: Py<PyArrayDyn<f64>>,
    d_wall: Py<PyArrayDyn<f64>>,
    d_pose: Py<PyArrayDyn<f64>>,
}

/// A finite pose `(x, y, theta)`.
fn pose3(pose: &Bound<'_, PyAny>) -> Result<Pose2, Error> {
    let p = float_vector(pose, "pose")?;
    match p[..] {
        [x, y, theta] if p.iter().all(|v| v.is_finite()) => Ok(Pose2 { x, y, theta }),
        _ => Err(Error::Value(format!(
            "pose must be 3 finite numbers (x, y, theta), got {} values",
            p.len()
        ))),
    }
}

/// Points `(N, 2)` in the frame of `pose = (x, y, theta)` moved to the world
/// (`inverse = false`), or world points expressed in that frame (`inverse = true`).
#[pyfunction]
#[pyo3(signature = (pose, points, inverse = false))]
pub fn pose_transform_points<'py>(
    py: Python<'py>,
    pose: &Bound<'py, PyAny>,
    points: &Bound<'py, PyAny>,
    inverse: bool,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let pose = pose3(pose)?;
    let rows = point_rows(points, "points")?;
    let pts = rows.as_points();
    let moved: Vec<f64> = pts
        .iter()
        .flat_map(|q: &Point2<f64>| {
            let r = if inverse {
                pose.inverse_transform_point(q)
            } else {
                pose.transform_point(q)
            };
            [r.x, r.y]
        })
        .collect();
    Ok(
        numpy::ndarray::Array2::from_shape_vec((pts.len(), 2), moved)
            .map_err(|e| Error::Value(e.to_string()))?
            .into_pyarray(py),
    )
}
