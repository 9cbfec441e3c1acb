//! Binding of the colour + template tracker (issue 34): conversion only.

use pyo3::prelude::*;
use tracking::{ColorTemplateParams, RgbFrame};

use crate::errors::{exclusive, shared};
use crate::tracking_py::{Threads, on_frame, start_on_box};

/// One answer of the colour + template tracker, frozen: the `box` `(x, y, w, h)`, the
/// `score`, the `lost` flag and the signals it was decided from: the merged response's
/// `peak`, the template response's `psr` and `apce`, the colour `color_score` and the
/// seed colour model's `contrast`.
#[pyclass(name = "ColorTemplateAnswer", module = "rperc._rperc", frozen, get_all)]
pub struct PyColorTemplateAnswer {
    #[pyo3(name = "box")]
    bbox: (f64, f64, f64, f64),
    score: f64,
    lost: bool,
    peak: f64,
    psr: f64,
    apce: f64,
    color_score: f64,
    contrast: f64,
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
            contrast: c.contrast,
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
        let class = "ColorTemplateTracker";
        let start = |view: RgbFrame<'_>, b, params: ColorTemplateParams| {
            tracking::ColorTemplateTracker::new(view, b, params)
        };
        let inner = start_on_box(py, frame, bbox, config, class, start)?;
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
        Ok(on_frame(py, frame, Threads::Caller, |view| tracker.update(view))?.into())
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
