//! Bindings of the `tracking` crate: the colour-histogram trackers (OpenCV-style
//! `update(frame) -> (box, score, lost)`) and the resamplers.

use numpy::{
    IntoPyArray, PyArray1, PyArrayDescrMethods, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use serde::de::DeserializeOwned;
use tracking::{
    BoundingBox, ColorTrackerParams, ParticleTrackerParams, Resampler, RgbFrame, TrackResult,
};

use crate::errors::{Error, detached, detached_parallel, exclusive, shared};

/// An H x W x 3 uint8 frame: borrowed when C-contiguous, copied otherwise.
pub(crate) enum FrameBuffer<'py> {
    Borrowed(numpy::PyReadonlyArray3<'py, u8>),
    Owned(Vec<u8>),
}

pub(crate) struct Frame<'py> {
    buffer: FrameBuffer<'py>,
    width: usize,
    height: usize,
}

impl Frame<'_> {
    pub(crate) fn view(&self) -> Result<RgbFrame<'_>, Error> {
        let data = match &self.buffer {
            FrameBuffer::Borrowed(a) => a.as_slice().map_err(|e| Error::Value(e.to_string()))?,
            FrameBuffer::Owned(v) => v.as_slice(),
        };
        Ok(RgbFrame::new(data, self.width, self.height)?)
    }
}

pub(crate) fn frame<'py>(obj: &Bound<'py, PyAny>) -> Result<Frame<'py>, Error> {
    let untyped = obj
        .cast::<PyUntypedArray>()
        .map_err(|_| Error::Type("frame must be a numpy array (H x W x 3, uint8)".into()))?;
    if !untyped.dtype().is_equiv_to(&numpy::dtype::<u8>(obj.py())) {
        return Err(Error::Type(format!(
            "frame must have dtype uint8, got {}",
            untyped.dtype()
        )));
    }
    let shape = untyped.shape().to_vec();
    if shape.len() != 3 || shape[2] != 3 {
        return Err(Error::Value(format!(
            "frame must have shape (H, W, 3) (RGB), got {shape:?}"
        )));
    }
    let array = obj
        .cast::<numpy::PyArray3<u8>>()
        .map_err(|e| Error::Type(e.to_string()))?
        .try_readonly()
        .map_err(|e| Error::Value(format!("frame is being written elsewhere: {e}")))?;
    let (height, width) = (shape[0], shape[1]);
    let buffer = if array.is_c_contiguous() {
        FrameBuffer::Borrowed(array)
    } else {
        FrameBuffer::Owned(array.as_array().iter().copied().collect())
    };
    Ok(Frame {
        buffer,
        width,
        height,
    })
}

/// A box `(x, y, w, h)` from any sequence of four numbers (tuple, list, ndarray).
pub(crate) fn bbox(obj: &Bound<'_, PyAny>) -> Result<BoundingBox, Error> {
    let v: Vec<f64> = obj
        .extract()
        .map_err(|_| Error::Type("box must be a sequence of 4 numbers (x, y, w, h)".into()))?;
    let [x, y, w, h] = v[..] else {
        return Err(Error::Value(format!(
            "box must have 4 numbers (x, y, w, h), got {}",
            v.len()
        )));
    };
    Ok(BoundingBox { x, y, w, h })
}

/// One answer of a colour-histogram tracker, frozen: the target's `box` `(x, y, w,
/// h)`, its `score` and whether it is `lost`.
#[pyclass(name = "TrackAnswer", module = "rperc._rperc", frozen, get_all)]
pub struct PyTrackAnswer {
    #[pyo3(name = "box")]
    bbox: (f64, f64, f64, f64),
    score: f64,
    lost: bool,
}

impl From<TrackResult> for PyTrackAnswer {
    fn from(r: TrackResult) -> Self {
        let [x, y, w, h] = r.bbox.to_array();
        Self {
            bbox: (x, y, w, h),
            score: r.score,
            lost: r.lost,
        }
    }
}

/// Birchfield's colour-histogram tracker with local search over position and scale.
#[pyclass(name = "ColorHistogramTracker", module = "rperc._rperc")]
pub struct PyColorHistogramTracker {
    inner: tracking::ColorHistogramTracker,
}

#[pymethods]
impl PyColorHistogramTracker {
    /// `config` holds `ColorTrackerParams` fields (`appearance` nested).
    #[new]
    #[pyo3(signature = (frame, bbox, config = None))]
    fn new(
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        bbox: &Bound<'_, PyAny>,
        config: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let class = "ColorHistogramTracker";
        let start = |view: RgbFrame<'_>, b, params: ColorTrackerParams| {
            tracking::ColorHistogramTracker::new(view, b, params)
        };
        let inner = start_on_box(py, frame, bbox, config, class, start)?;
        Ok(Self { inner })
    }

    /// Tracks the target into `frame`.
    fn update(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
    ) -> PyResult<PyTrackAnswer> {
        let mut this = exclusive(slf)?;
        let tracker = &mut this.inner;
        Ok(on_frame(py, frame, Threads::Caller, |view| tracker.update(view))?.into())
    }

    /// The current scale relative to the initial box.
    #[getter]
    fn scale(slf: &Bound<'_, Self>) -> PyResult<f64> {
        Ok(shared(slf)?.inner.scale())
    }

    /// Half-size in pixels of the next frame's search window.
    #[getter]
    fn search_radius(slf: &Bound<'_, Self>) -> PyResult<usize> {
        Ok(shared(slf)?.inner.search_radius())
    }

    /// Frames in a row the target has been lost (0 while tracked).
    #[getter]
    fn lost_frames(slf: &Bound<'_, Self>) -> PyResult<usize> {
        Ok(shared(slf)?.inner.lost_frames())
    }
}

/// The CONDENSATION colour tracker over (x, y, scale).
#[pyclass(name = "ParticleColorTracker", module = "rperc._rperc")]
pub struct PyParticleColorTracker {
    inner: tracking::ParticleColorTracker,
}

#[pymethods]
impl PyParticleColorTracker {
    /// `config` holds `ParticleTrackerParams` fields (`appearance`, `filter` nested).
    #[new]
    #[pyo3(signature = (frame, bbox, seed = 0, config = None))]
    fn new(
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        bbox: &Bound<'_, PyAny>,
        seed: u64,
        config: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let class = "ParticleColorTracker";
        let start = |view: RgbFrame<'_>, b, params: ParticleTrackerParams| {
            tracking::ParticleColorTracker::new(view, b, params, seed)
        };
        let inner = start_on_box(py, frame, bbox, config, class, start)?;
        Ok(Self { inner })
    }

    /// Tracks the target into `frame`.
    fn update(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
    ) -> PyResult<PyTrackAnswer> {
        let mut this = exclusive(slf)?;
        let tracker = &mut this.inner;
        // The particles are weighed on the thread pool.
        Ok(on_frame(py, frame, Threads::Pool, |view| tracker.update(view))?.into())
    }

    /// Effective sample size of the particle set.
    #[getter]
    fn ess(slf: &Bound<'_, Self>) -> PyResult<f64> {
        Ok(shared(slf)?.inner.filter().ess())
    }
}

/// Where a tracker's work runs with the GIL released.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Threads {
    /// On the calling thread ([`detached`]).
    Caller,
    /// On the thread pool, whose threads cannot ask Python for signals: the calling
    /// thread polls for Ctrl-C while a worker steps ([`detached_parallel`]).
    Pool,
}

/// Runs `work` on the numpy RGB `frame` with the GIL released: the one reading of a
/// tracker's frame for its first frame and its steps.
pub(crate) fn on_frame<R, F>(
    py: Python<'_>,
    frame: &Bound<'_, PyAny>,
    threads: Threads,
    work: F,
) -> PyResult<R>
where
    R: Send,
    F: FnOnce(RgbFrame<'_>) -> tracking::Result<R> + Send,
{
    let f = self::frame(frame)?;
    let view = f.view()?;
    let work = || Ok(work(view)?);
    match threads {
        Threads::Caller => detached(py, work),
        Threads::Pool => detached_parallel(py, work),
    }
}

/// Starts a box tracker on its first frame with the GIL released: `config` read as its
/// parameters (errors name `class`), the box checked, then `start`.
pub(crate) fn start_on_box<P, T, F>(
    py: Python<'_>,
    frame: &Bound<'_, PyAny>,
    bbox: &Bound<'_, PyAny>,
    config: Option<&Bound<'_, PyAny>>,
    class: &str,
    start: F,
) -> PyResult<T>
where
    P: DeserializeOwned + Default + Send,
    T: Send,
    F: FnOnce(RgbFrame<'_>, BoundingBox, P) -> tracking::Result<T> + Send,
{
    let params: P = crate::config::from_python(config, class)?;
    let b = self::bbox(bbox)?;
    on_frame(py, frame, Threads::Caller, move |view| {
        start(view, b, params)
    })
}

/// Indices of `n` particles drawn from `weights` by `method`, seeded (GIL released).
#[pyfunction]
#[pyo3(signature = (weights, n, method = "systematic", seed = 0))]
pub fn resample<'py>(
    py: Python<'py>,
    weights: &Bound<'py, PyAny>,
    n: usize,
    method: &str,
    seed: u64,
) -> PyResult<Bound<'py, PyArray1<isize>>> {
    let w = crate::arrays::float_vector(weights, "weights")?;
    let method: Resampler = method.parse().map_err(Error::from)?;
    let out = detached(py, || {
        let mut rng = rperc_core::rng::seeded(seed);
        let mut out = Vec::new();
        method.resample(&w, n, &mut rng, &mut out)?;
        Ok(out.into_iter().map(|k| k as isize).collect::<Vec<_>>())
    })?;
    Ok(out.into_pyarray(py))
}

/// Effective sample size `(sum w)^2 / sum(w^2)` of non-negative weights.
#[pyfunction]
pub fn effective_sample_size(weights: &Bound<'_, PyAny>) -> PyResult<f64> {
    let w = crate::arrays::float_vector(weights, "weights")?;
    Ok(tracking::effective_sample_size(&w).map_err(Error::from)?)
}
