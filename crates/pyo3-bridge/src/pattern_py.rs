//! Bindings of the 2-D pattern tracker (seed 001 section 3) and its Fig. 8 sequence
//! generator (section 4.1).

use numpy::{
    IntoPyArray, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use rperc_core::image::{GrayImage, GrayView, RgbView};
use tracking::{PatternFrame, PatternPose, PatternTrackerParams, Region, SequenceParams};

use crate::errors::{Error, detached, detached_parallel, exclusive};

/// An `H x W` or `H x W x 3` uint8 frame: borrowed when C-contiguous, copied otherwise.
struct Frame<'py> {
    borrowed: Option<numpy::PyReadonlyArrayDyn<'py, u8>>,
    owned: Vec<u8>,
    width: usize,
    height: usize,
    rgb: bool,
}

impl Frame<'_> {
    fn view(&self) -> Result<PatternFrame<'_>, Error> {
        let data = match &self.borrowed {
            Some(a) => a.as_slice().map_err(|e| Error::Value(e.to_string()))?,
            None => self.owned.as_slice(),
        };
        Ok(if self.rgb {
            PatternFrame::Rgb(RgbView::new(data, self.width, self.height)?)
        } else {
            PatternFrame::Gray(GrayView::new(data, self.width, self.height)?)
        })
    }
}

fn frame<'py>(obj: &Bound<'py, PyAny>) -> Result<Frame<'py>, Error> {
    let untyped = obj.cast::<PyUntypedArray>().map_err(|_| {
        Error::Type("frame must be a numpy array (H x W or H x W x 3, uint8)".into())
    })?;
    if !untyped.dtype().is_equiv_to(&numpy::dtype::<u8>(obj.py())) {
        return Err(Error::Type(format!(
            "frame must have dtype uint8, got {}",
            untyped.dtype()
        )));
    }
    let shape = untyped.shape().to_vec();
    let rgb = match shape[..] {
        [_, _] => false,
        [_, _, 3] => true,
        _ => {
            return Err(Error::Value(format!(
                "frame must have shape (H, W) or (H, W, 3), got {shape:?}"
            )));
        }
    };
    let array = obj
        .cast::<PyArrayDyn<u8>>()
        .map_err(|e| Error::Type(e.to_string()))?
        .try_readonly()
        .map_err(|e| Error::Value(format!("frame is being written elsewhere: {e}")))?;
    let (borrowed, owned) = if array.is_c_contiguous() {
        (Some(array), Vec::new())
    } else {
        (None, array.as_array().iter().copied().collect())
    };
    Ok(Frame {
        borrowed,
        owned,
        width: shape[1],
        height: shape[0],
        rgb,
    })
}

/// The region a tracker learns from: a box or mask ([`Region`]) or four corners.
enum Area {
    Region(Region),
    Corners([[f64; 2]; 4]),
}

/// A `(4, 2)` float64 array of corners (top-left, top-right, bottom-right,
/// bottom-left), or [`region`]'s box or mask.
fn area(obj: &Bound<'_, PyAny>, width: usize, height: usize) -> Result<Area, Error> {
    if let Ok(quad) = obj.cast::<numpy::PyArray2<f64>>() {
        let shape = quad.shape().to_vec();
        if shape != [4, 2] {
            return Err(Error::Value(format!(
                "region corners must have shape (4, 2), got {shape:?}"
            )));
        }
        let a = quad.readonly();
        let a = a.as_array();
        let corners = std::array::from_fn(|i| [a[(i, 0)], a[(i, 1)]]);
        return Ok(Area::Corners(corners));
    }
    Ok(Area::Region(region(obj, width, height)?))
}

/// A box `(x, y, w, h)` of non-negative integers, or a boolean mask the frame's size.
fn region(obj: &Bound<'_, PyAny>, width: usize, height: usize) -> Result<Region, Error> {
    if let Ok(mask) = obj.cast::<numpy::PyArray2<bool>>() {
        let shape = mask.shape();
        if shape != [height, width] {
            return Err(Error::Value(format!(
                "region mask must have the frame's shape ({height}, {width}), got {shape:?}"
            )));
        }
        let cells = mask.readonly().as_array().iter().copied().collect();
        return Ok(Region::Mask(cells));
    }
    let v: Vec<i64> = obj.extract().map_err(|_| {
        Error::Type("region must be 4 integers (x, y, w, h) or a boolean mask".into())
    })?;
    let [x, y, w, h] = v[..] else {
        return Err(Error::Value(format!(
            "region must have 4 integers (x, y, w, h), got {}",
            v.len()
        )));
    };
    let as_usize = |v: i64| usize::try_from(v).ok();
    match (as_usize(x), as_usize(y), as_usize(w), as_usize(h)) {
        (Some(x), Some(y), Some(w), Some(h)) => Ok(Region::Box { x, y, w, h }),
        _ => Err(Error::Value(format!(
            "region ({x}, {y}, {w}, {h}) is not inside the {width}x{height} frame"
        ))),
    }
}

/// One answer of the pattern tracker, frozen: the state `x, y, theta, scale`, the
/// `score`, the `occluded_fraction`, the `lost` flag, the region's `corners` moved by
/// the pose (a read-only `(4, 2)` float64 array: top-left, top-right, bottom-right,
/// bottom-left) and the `homography` from the first frame (read-only `(3, 3)`).
#[pyclass(name = "PatternAnswer", module = "rperc._rperc", frozen, get_all)]
pub struct PyPatternAnswer {
    x: f64,
    y: f64,
    theta: f64,
    scale: f64,
    score: f64,
    occluded_fraction: f64,
    lost: bool,
    corners: Py<numpy::PyArray2<f64>>,
    homography: Py<numpy::PyArray2<f64>>,
}

/// `rows` as a `(R, C)` float64 array nobody can write to: the answer is frozen.
fn read_only<'py, const R: usize, const C: usize>(
    py: Python<'py>,
    rows: &[[f64; C]; R],
) -> PyResult<Py<numpy::PyArray2<f64>>> {
    let array = numpy::ndarray::Array2::from_shape_fn((R, C), |(i, j)| rows[i][j]).into_pyarray(py);
    array.getattr("flags")?.setattr("writeable", false)?;
    Ok(array.unbind())
}

fn answer(py: Python<'_>, p: PatternPose) -> PyResult<PyPatternAnswer> {
    let [x, y, theta, scale] = p.state;
    Ok(PyPatternAnswer {
        x,
        y,
        theta,
        scale,
        score: p.score,
        occluded_fraction: p.occluded_fraction,
        lost: p.lost,
        corners: read_only(py, &p.corners)?,
        homography: read_only(py, &p.homography)?,
    })
}

/// The CONDENSATION pattern tracker over (x, y, theta, s), or the plane's homography.
#[pyclass(name = "PatternTracker", module = "rperc._rperc")]
pub struct PyPatternTracker {
    inner: tracking::PatternTracker,
}

#[pymethods]
impl PyPatternTracker {
    /// `config` holds `PatternTrackerParams` fields (`pattern`, `filter` nested).
    #[new]
    #[pyo3(signature = (frame, region, seed = 0, config = None))]
    fn new(
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        region: &Bound<'_, PyAny>,
        seed: u64,
        config: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let params: PatternTrackerParams = crate::config::from_python(config, "PatternTracker")?;
        let f = self::frame(frame)?;
        let r = self::area(region, f.width, f.height)?;
        let view = f.view()?;
        let inner = detached(py, || {
            Ok(match r {
                Area::Region(r) => tracking::PatternTracker::new(view, r, params, seed)?,
                Area::Corners(c) => tracking::PatternTracker::with_corners(view, c, params, seed)?,
            })
        })?;
        Ok(Self { inner })
    }

    /// One step on the next frame (GIL released).
    fn update<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
    ) -> PyResult<PyPatternAnswer> {
        let mut this = exclusive(slf)?;
        let tracker = &mut this.inner;
        let f = self::frame(frame)?;
        let view = f.view()?;
        // A large model's step runs on the thread pool, whose threads cannot ask
        // Python for signals: this thread polls for Ctrl-C while a worker steps. A
        // serial step runs here and polls itself, without a thread spawned per frame
        // (about 40 us of a 1 ms step).
        let pose = match tracker.runs_on_pool() {
            true => detached_parallel(py, || Ok(tracker.update(view)?))?,
            false => detached(py, || Ok(tracker.update(view)?))?,
        };
        answer(py, pose)
    }

    /// The last answer: the initial pose (score 1) before the first update, its
    /// corners those of the region as the tracker placed them.
    #[getter]
    fn last(slf: &Bound<'_, Self>, py: Python<'_>) -> PyResult<PyPatternAnswer> {
        let pose = crate::errors::shared(slf)?.inner.last();
        answer(py, pose)
    }

    /// Number of points of the learnt model.
    #[getter]
    fn n_points(slf: &Bound<'_, Self>) -> PyResult<usize> {
        Ok(crate::errors::shared(slf)?.inner.model().points.len())
    }

    /// The model points' offsets from the model's centre at scale 1, `(n, 2)`
    /// float64 (pixels of the region, or of its rectified quad).
    #[getter]
    fn model_offsets<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        let this = crate::errors::shared(slf)?;
        let model = this.inner.model();
        let n = model.points.len();
        let offsets = numpy::ndarray::Array2::from_shape_fn((n, 2), |(j, d)| model.offset(j)[d]);
        Ok(offsets.into_pyarray(py))
    }
}

/// A 2-D float array as a grey image.
fn gray_image(obj: &Bound<'_, PyAny>, name: &str) -> Result<GrayImage, Error> {
    let (shape, data) = crate::arrays::tensor(obj, name, 2)?;
    Ok(GrayImage {
        data: data.into_iter().map(|v| v as f32).collect(),
        width: shape[1],
        height: shape[0],
    })
}

/// A generated sequence, frozen: `frames` `(n, H, W)` uint8, `truth` `(n, 4)` states
/// `(x, y, theta, scale)`, `occlusion` `(n,)`, `illumination` `(n, 2)` gain and
/// offset, and the `region` `(x, y, w, h)` the patch fills in frame 0.
#[pyclass(
    name = "PatternSequenceAnswer",
    module = "rperc._rperc",
    frozen,
    get_all
)]
pub struct PyPatternSequence {
    frames: Py<PyArrayDyn<u8>>,
    truth: Py<PyArrayDyn<f64>>,
    occlusion: Py<PyArrayDyn<f64>>,
    illumination: Py<PyArrayDyn<f64>>,
    region: (usize, usize, usize, usize),
}

/// The Fig. 8 sequence (section 4.1) of `patch` over `background` (GIL released).
#[pyfunction]
#[pyo3(signature = (patch, background, config = None))]
pub fn pattern_sequence<'py>(
    py: Python<'py>,
    patch: &Bound<'py, PyAny>,
    background: &Bound<'py, PyAny>,
    config: Option<&Bound<'py, PyAny>>,
) -> PyResult<PyPatternSequence> {
    let params: SequenceParams = crate::config::from_python(config, "pattern_sequence")?;
    let patch = gray_image(patch, "patch")?;
    let background = gray_image(background, "background")?;
    let seq = detached(py, || {
        Ok(tracking::generate_sequence(&patch, &background, &params)?)
    })?;
    let n = seq.truth.len();
    let frames = numpy::ndarray::ArrayD::from_shape_vec(
        numpy::ndarray::IxDyn(&[n, params.height, params.width]),
        seq.frames,
    )
    .map_err(|e| Error::Value(format!("internal shape error: {e}")))?;
    let flat = |rows: Vec<[f64; 4]>| rows.into_iter().flatten().collect::<Vec<f64>>();
    let illumination: Vec<f64> = seq.illumination.into_iter().flatten().collect();
    let [x, y, w, h] = seq.region;
    Ok(PyPatternSequence {
        frames: frames.into_pyarray(py).unbind(),
        truth: crate::arrays::shaped(py, flat(seq.truth), &[n, 4])?.unbind(),
        occlusion: crate::arrays::shaped(py, seq.occlusion, &[n])?.unbind(),
        illumination: crate::arrays::shaped(py, illumination, &[n, 2])?.unbind(),
        region: (x, y, w, h),
    })
}
