//! Binding of the colour + template tracker (issue 34): conversion only.

use pyo3::prelude::*;
use tracking::ColorTemplateParams;

use crate::errors::{detached, exclusive, shared};
use crate::tracking_py::{Answer, bbox, frame, track};

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

    /// Tracks the target into `frame`: `((x, y, w, h), score, lost)`.
    fn update(slf: &Bound<'_, Self>, py: Python<'_>, frame: &Bound<'_, PyAny>) -> PyResult<Answer> {
        let mut this = exclusive(slf)?;
        let tracker = &mut this.inner;
        track(py, frame, |view| tracker.update(view))
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

/// The default `ColorTemplateParams` as a dict.
#[pyfunction]
pub fn color_template_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    crate::config::defaults::<ColorTemplateParams>(py)
}
