//! Bindings of the colour+shape tracker (`tracking::ColorShapeTracker`).

use numpy::PyArray2;
use pyo3::prelude::*;
use tracking::{ColorShapeParams, ColorShapeResult};

use crate::errors::{Error, detached, exclusive};
use crate::tracking_py::{Threads, bbox, frame, on_frame};

/// One answer of the colour+shape tracker, frozen: the `contour` (a read-only
/// `(N, 2)` float64 array of `(x, y)`), its bounding `box` `(x, y, w, h)`, the colour
/// `distribution` `(mR, mG, mB, l1, l2, l3, theta, phi)`, the best sample's `score`,
/// the `lost` flag and the particle set's effective sample size `ess`.
#[pyclass(name = "ColorShapeAnswer", module = "rperc._rperc", frozen, get_all)]
pub struct PyColorShapeAnswer {
    contour: Py<PyArray2<f64>>,
    #[pyo3(name = "box")]
    bbox: (f64, f64, f64, f64),
    distribution: (f64, f64, f64, f64, f64, f64, f64, f64),
    score: f64,
    lost: bool,
    ess: f64,
}

fn answer(py: Python<'_>, r: ColorShapeResult) -> PyResult<PyColorShapeAnswer> {
    let n = r.contour.len();
    let flat: Vec<f64> = r.contour.iter().flatten().copied().collect();
    let contour = numpy::ndarray::Array2::from_shape_vec((n, 2), flat)
        .map_err(|e| Error::Value(format!("internal shape error: {e}")))?;
    let contour = numpy::IntoPyArray::into_pyarray(contour, py);
    contour.getattr("flags")?.setattr("writeable", false)?;
    let [x, y, w, h] = r.bbox.to_array();
    let [m_r, m_g, m_b, l1, l2, l3, theta, phi] = r.distribution;
    Ok(PyColorShapeAnswer {
        contour: contour.unbind(),
        bbox: (x, y, w, h),
        distribution: (m_r, m_g, m_b, l1, l2, l3, theta, phi),
        score: r.score,
        lost: r.lost,
        ess: r.ess,
    })
}

/// CONDENSATION over the target's colour distribution, weighted by an affine snake.
#[pyclass(name = "ColorShapeTracker", module = "rperc._rperc")]
pub struct PyColorShapeTracker {
    inner: tracking::ColorShapeTracker,
}

#[pymethods]
impl PyColorShapeTracker {
    /// Starts on `frame` from a closed `contour` ((N, 2) floats, x then y) or, when
    /// `contour` is None, from the ellipse inscribed in `bbox`. `config` holds
    /// `ColorShapeParams` fields.
    #[new]
    #[pyo3(signature = (frame, bbox = None, contour = None, config = None))]
    fn new(
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        bbox: Option<&Bound<'_, PyAny>>,
        contour: Option<&Bound<'_, PyAny>>,
        config: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let params: ColorShapeParams = crate::config::from_python(config, "ColorShapeTracker")?;
        let f = self::frame(frame)?;
        let view = f.view()?;
        let inner = match (contour, bbox) {
            (Some(c), _) => {
                let rows = crate::arrays::point_rows(c, "contour")?;
                let pts: Vec<[f64; 2]> = rows.as_points().iter().map(|p| [p.x, p.y]).collect();
                detached(py, || {
                    Ok(tracking::ColorShapeTracker::new(view, &pts, params)?)
                })?
            }
            (None, Some(b)) => {
                let b = self::bbox(b)?;
                detached(py, || {
                    Ok(tracking::ColorShapeTracker::from_box(view, b, params)?)
                })?
            }
            (None, None) => {
                return Err(Error::Value("give a box or a contour".into()).into());
            }
        };
        Ok(Self { inner })
    }

    /// Tracks into `frame`.
    fn update(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
    ) -> PyResult<PyColorShapeAnswer> {
        let mut this = exclusive(slf)?;
        let tracker = &mut this.inner;
        // The samples are weighed on the thread pool.
        let r = on_frame(py, frame, Threads::Pool, |view| tracker.update(view))?;
        answer(py, r)
    }
}

/// The raw and the cleaned segmentation, (H, W) uint8 each.
type Masks<'py> = (Bound<'py, PyArray2<u8>>, Bound<'py, PyArray2<u8>>);

/// The seed's segmentation of `frame` by the histogram of `colours` ((N, 3) floats in
/// the colour space's `[0, 1)` coordinates): `(raw, cleaned)`, two (H, W) uint8 masks
/// (0 or 255), the second after the opening and closing of half-side `radius`.
#[pyfunction]
#[pyo3(signature = (frame, colours, color_space, bins, radius))]
pub fn color_segment<'py>(
    py: Python<'py>,
    frame: &Bound<'py, PyAny>,
    colours: numpy::PyReadonlyArray2<'py, f64>,
    color_space: &str,
    bins: [usize; 3],
    radius: u8,
) -> PyResult<Masks<'py>> {
    let space = match color_space {
        "rgb" => tracking::ColorSpace::Rgb,
        "opponent" => tracking::ColorSpace::Opponent,
        _ => return Err(Error::Value("color_space must be 'rgb' or 'opponent'".into()).into()),
    };
    let c = colours.as_array();
    if c.ncols() != 3 {
        return Err(Error::Value(format!(
            "colours must have shape (N, 3), got {:?}",
            c.shape()
        ))
        .into());
    }
    let cloud: Vec<[f64; 3]> = c.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
    let f = self::frame(frame)?;
    let view = f.view()?;
    let (raw, cleaned) = detached(py, || {
        Ok(tracking::colour_segment(
            &view, &cloud, space, bins, radius,
        )?)
    })?;
    let shape = (raw.height() as usize, raw.width() as usize);
    let to_array = |data: Vec<u8>| {
        numpy::ndarray::Array2::from_shape_vec(shape, data)
            .map(|a| numpy::IntoPyArray::into_pyarray(a, py))
            .map_err(|e| Error::Value(format!("internal shape error: {e}")))
    };
    Ok((to_array(raw.into_raw())?, to_array(cleaned.into_raw())?))
}
