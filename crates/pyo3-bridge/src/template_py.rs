//! Binding of the colour + template tracker (issue 34): conversion only.

use pyo3::prelude::*;
use tracking::ColorTemplateParams;

use crate::errors::{detached, exclusive, shared};
use crate::tracking_py::{bbox, frame};

/// One answer of the colour + template tracker, frozen: the `box` `(x, y, w, h)`, the
/// `score`, the `lost` flag and the signals it was decided from: the merged response's
/// `peak`, the template response's `psr` and `apce`, and the colour `color_score`.
#[pyclass(name = "ColorTemplateAnswer", module = "rperc._rperc", frozen)]
pub struct PyColorTemplateAnswer {
    #[pyo3(get, name = "box")]
    bbox: (f64, f64, f64, f64),
    #[pyo3(get)]
    score: f64,
    #[pyo3(get)]
    lost: bool,
    #[pyo3(get)]
    peak: f64,
    #[pyo3(get)]
    psr: f64,
    #[pyo3(get)]
    apce: f64,
    #[pyo3(get)]
    color_score: f64,
}

impl From<tracking::TemplateResult> for PyColorTemplateAnswer {
    fn from(r: tracking::TemplateResult) -> Self {
        let [x, y, w, h] = r.bbox.to_array();
        let c = r.confidence;
        Self {
            bbox: (x, y, w, h),
            score: r.score,
            lost: r.lost,
            peak: c.peak,
            psr: c.psr,
            apce: c.apce,
            color_score: c.color_score,
        }
    }
}

/// Staple-style colour + correlation-filter template tracker with DSST scale.
#[pyclass(name = "ColorTemplateTracker", module = "rperc._rperc")]
pub struct PyColorTemplateTracker {
    inner: tracking::ColorTemplateTracker,
}

#[pymethods]
impl PyColorTemplateTracker {
    /// `config` holds `ColorTemplateParams` fields. `seed` is accepted for the common
    /// tracker signature; the tracker draws no random numbers.
    #[new]
    #[pyo3(signature = (frame, bbox, seed = 0, config = None))]
    fn new(
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        bbox: &Bound<'_, PyAny>,
        seed: u64,
        config: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let _ = seed;
        let params: ColorTemplateParams =
            crate::config::from_python(config, "ColorTemplateTracker")?;
        let b = self::bbox(bbox)?;
        let f = self::frame(frame)?;
        let view = f.view()?;
        let inner = detached(py, || {
            Ok(tracking::ColorTemplateTracker::new(view, b, params)?)
        })?;
        Ok(Self { inner })
    }

    /// Tracks the target into `frame`.
    fn update(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
    ) -> PyResult<PyColorTemplateAnswer> {
        let mut this = exclusive(slf)?;
        let tracker = &mut this.inner;
        let f = self::frame(frame)?;
        let view = f.view()?;
        let r = detached(py, || Ok(tracker.update(view)?))?;
        Ok(r.into())
    }

    /// The current scale relative to the initial box.
    #[getter]
    fn scale(slf: &Bound<'_, Self>) -> PyResult<f64> {
        Ok(shared(slf)?.inner.scale())
    }

    /// Frames in a row the target has been lost (0 while tracked).
    #[getter]
    fn lost_frames(slf: &Bound<'_, Self>) -> PyResult<usize> {
        Ok(shared(slf)?.inner.lost_frames())
    }
}
