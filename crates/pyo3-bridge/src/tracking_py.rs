//! Bindings of the `tracking` crate: the colour-histogram trackers (OpenCV-style
//! `update(frame) -> (box, score, lost)`) and the resamplers.

use numpy::{
    IntoPyArray, PyArray1, PyArrayDescrMethods, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rand::SeedableRng;
use tracking::{
    AppearanceParams, BoundingBox, ColorSpace, ColorTrackerParams, FilterParams, ModelKind,
    ParticleTrackerParams, ResamplePolicy, Resampler, RgbFrame, TrackResult,
};

use crate::errors::{Error, detached};

/// An H x W x 3 uint8 frame: borrowed when C-contiguous, copied otherwise.
enum FrameBuffer<'py> {
    Borrowed(numpy::PyReadonlyArray3<'py, u8>),
    Owned(Vec<u8>),
}

struct Frame<'py> {
    buffer: FrameBuffer<'py>,
    width: usize,
    height: usize,
}

impl Frame<'_> {
    fn view(&self) -> Result<RgbFrame<'_>, Error> {
        let data = match &self.buffer {
            FrameBuffer::Borrowed(a) => a.as_slice().map_err(|e| Error::Value(e.to_string()))?,
            FrameBuffer::Owned(v) => v.as_slice(),
        };
        Ok(RgbFrame::new(data, self.width, self.height)?)
    }
}

fn frame<'py>(obj: &Bound<'py, PyAny>) -> Result<Frame<'py>, Error> {
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

fn bbox(b: (f64, f64, f64, f64)) -> BoundingBox {
    BoundingBox {
        x: b.0,
        y: b.1,
        w: b.2,
        h: b.3,
    }
}

type Answer = ((f64, f64, f64, f64), f64, bool);

fn answer(r: TrackResult) -> Answer {
    let [x, y, w, h] = r.bbox.to_array();
    ((x, y, w, h), r.score, r.lost)
}

/// Keyword parameters, consumed one by one so that a misspelt one is an error.
struct Params<'py> {
    dict: Option<Bound<'py, PyDict>>,
}

impl<'py> Params<'py> {
    /// Owns a copy of the caller's keyword dict, so consuming it changes nothing outside.
    fn new(params: Option<Bound<'py, PyDict>>) -> PyResult<Self> {
        Ok(Self {
            dict: params.map(|d| d.copy()).transpose()?,
        })
    }

    /// Overwrites `slot` when the parameter was given.
    fn set<T: for<'a> FromPyObject<'a, 'py>>(&self, name: &str, slot: &mut T) -> Result<(), Error> {
        if let Some(v) = self.take(name)? {
            *slot = v;
        }
        Ok(())
    }

    fn take<T: for<'a> FromPyObject<'a, 'py>>(&self, name: &str) -> Result<Option<T>, Error> {
        let Some(dict) = &self.dict else {
            return Ok(None);
        };
        match dict
            .get_item(name)
            .map_err(|e| Error::Value(e.to_string()))?
        {
            None => Ok(None),
            Some(v) => {
                dict.del_item(name)
                    .map_err(|e| Error::Value(e.to_string()))?;
                v.extract::<T>()
                    .map(Some)
                    .map_err(|_| Error::Type(format!("parameter '{name}' has the wrong type")))
            }
        }
    }

    fn finish(self) -> Result<(), Error> {
        match self.dict {
            Some(d) if !d.is_empty() => Err(Error::Type(format!(
                "unknown parameter(s): {}",
                d.keys()
                    .iter()
                    .map(|k| k.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))),
            _ => Ok(()),
        }
    }

    fn appearance(&self) -> Result<AppearanceParams, Error> {
        let mut a = AppearanceParams::default();
        if let Some(space) = self.take::<String>("color_space")? {
            a.color_space = match space.as_str() {
                "rgb" => ColorSpace::Rgb,
                "opponent" => ColorSpace::Opponent,
                "rg" => ColorSpace::NormalizedRg,
                "hsv" => ColorSpace::Hsv,
                other => {
                    return Err(Error::Value(format!(
                        "color_space must be 'rgb', 'opponent', 'rg' or 'hsv', got '{other}'"
                    )));
                }
            };
        }
        if let Some(bins) = self.take::<(usize, usize, usize)>("bins")? {
            a.bins = [bins.0, bins.1, bins.2];
        }
        let upper = self.take::<f64>("upper_fraction")?;
        match self.take::<String>("model")?.as_deref() {
            None | Some("bimodal") => {
                if let Some(f) = upper {
                    a.model = ModelKind::Bimodal { upper_fraction: f };
                }
            }
            Some("single") => a.model = ModelKind::Single,
            Some(other) => {
                return Err(Error::Value(format!(
                    "model must be 'single' or 'bimodal', got '{other}'"
                )));
            }
        }
        self.set("adaptation_rate", &mut a.adaptation_rate)?;
        self.set("adaptation_threshold", &mut a.adaptation_threshold)?;
        self.set("gradient_weight", &mut a.gradient_weight)?;
        self.set("lost_threshold", &mut a.lost_threshold)?;
        Ok(a)
    }
}

/// Birchfield's colour-histogram tracker with local search over position and scale.
#[pyclass(name = "ColorHistogramTracker", module = "rperc._rperc")]
pub struct PyColorHistogramTracker {
    inner: tracking::ColorHistogramTracker,
}

#[pymethods]
impl PyColorHistogramTracker {
    #[new]
    #[pyo3(signature = (frame, r#box, **params))]
    fn new(
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        r#box: (f64, f64, f64, f64),
        params: Option<Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let p = Params::new(params)?;
        let mut tp = ColorTrackerParams {
            appearance: p.appearance()?,
            ..ColorTrackerParams::default()
        };
        p.set("search_radius", &mut tp.search_radius)?;
        p.set("scale_step", &mut tp.scale_step)?;
        p.set("min_scale", &mut tp.min_scale)?;
        p.set("max_scale", &mut tp.max_scale)?;
        p.set("momentum", &mut tp.momentum)?;
        p.set("parallel", &mut tp.parallel)?;
        p.finish()?;
        let f = frame_arg(frame)?;
        let view = f.view()?;
        let inner = detached(py, || {
            Ok(tracking::ColorHistogramTracker::new(view, bbox(r#box), tp)?)
        })?;
        Ok(Self { inner })
    }

    /// Tracks the target into `frame`: `((x, y, w, h), score, lost)`.
    fn update(&mut self, py: Python<'_>, frame: &Bound<'_, PyAny>) -> PyResult<Answer> {
        let tracker = &mut self.inner;
        track(py, frame, |view| tracker.update(view))
    }

    /// The current scale relative to the initial box.
    #[getter]
    fn scale(&self) -> f64 {
        self.inner.scale()
    }
}

/// The CONDENSATION colour tracker over (x, y, scale).
#[pyclass(name = "ParticleColorTracker", module = "rperc._rperc")]
pub struct PyParticleColorTracker {
    inner: tracking::ParticleColorTracker,
}

#[pymethods]
impl PyParticleColorTracker {
    #[new]
    #[pyo3(signature = (frame, r#box, seed = 0, **params))]
    fn new(
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        r#box: (f64, f64, f64, f64),
        seed: u64,
        params: Option<Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let p = Params::new(params)?;
        let mut tp = ParticleTrackerParams {
            appearance: p.appearance()?,
            ..ParticleTrackerParams::default()
        };
        p.set("n_particles", &mut tp.n_particles)?;
        p.set("position_noise", &mut tp.position_noise)?;
        p.set("scale_noise", &mut tp.scale_noise)?;
        p.set("sigma", &mut tp.sigma)?;
        p.set("min_scale", &mut tp.min_scale)?;
        p.set("max_scale", &mut tp.max_scale)?;
        tp.filter = filter_params(&p, tp.filter)?;
        p.finish()?;
        let f = frame_arg(frame)?;
        let view = f.view()?;
        let inner = detached(py, || {
            Ok(tracking::ParticleColorTracker::new(
                view,
                bbox(r#box),
                tp,
                seed,
            )?)
        })?;
        Ok(Self { inner })
    }

    /// Tracks the target into `frame`: `((x, y, w, h), score, lost)`.
    fn update(&mut self, py: Python<'_>, frame: &Bound<'_, PyAny>) -> PyResult<Answer> {
        let tracker = &mut self.inner;
        track(py, frame, |view| tracker.update(view))
    }

    /// Effective sample size of the particle set.
    #[getter]
    fn ess(&self) -> f64 {
        self.inner.filter().ess()
    }
}

fn frame_arg<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Frame<'py>> {
    Ok(frame(obj)?)
}

/// Runs one tracker step on a numpy frame with the GIL released.
fn track<F>(py: Python<'_>, frame: &Bound<'_, PyAny>, step: F) -> PyResult<Answer>
where
    F: FnOnce(RgbFrame<'_>) -> tracking::Result<TrackResult> + Send,
{
    let f = frame_arg(frame)?;
    let view = f.view()?;
    Ok(answer(detached(py, || Ok(step(view)?))?))
}

fn resampler(name: &str) -> Result<Resampler, Error> {
    match name {
        "multinomial" => Ok(Resampler::Multinomial),
        "systematic" => Ok(Resampler::Systematic),
        "stratified" => Ok(Resampler::Stratified),
        "residual" => Ok(Resampler::Residual),
        other => Err(Error::Value(format!(
            "resampler must be 'multinomial', 'systematic', 'stratified' or 'residual', got '{other}'"
        ))),
    }
}

fn filter_params(p: &Params<'_>, mut f: FilterParams) -> Result<FilterParams, Error> {
    if let Some(name) = p.take::<String>("resampler")? {
        f.resampler = resampler(&name)?;
    }
    if let Some(fraction) = p.take::<f64>("resample_below")? {
        f.policy = ResamplePolicy::BelowEss(fraction);
    }
    p.set("chunk_size", &mut f.chunk_size)?;
    p.set("parallel", &mut f.parallel)?;
    Ok(f)
}

/// Indices of `n` particles drawn from `weights` by `method`, seeded.
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
    let method = resampler(method)?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    method
        .resample(&w, n, &mut rng, &mut out)
        .map_err(Error::from)?;
    let out: Vec<isize> = out.into_iter().map(|k| k as isize).collect();
    Ok(out.into_pyarray(py))
}

/// Effective sample size `1 / sum(w^2)` of normalised weights.
#[pyfunction]
pub fn effective_sample_size(weights: &Bound<'_, PyAny>) -> PyResult<f64> {
    Ok(tracking::effective_sample_size(
        &crate::arrays::float_vector(weights, "weights")?,
    ))
}
