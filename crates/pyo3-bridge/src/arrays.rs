//! numpy in: one dtype and layout dispatch for every float array, with shape checks.
//!
//! An aligned, native-endian float64 array is borrowed as it is. Anything else that
//! holds floats (float32, big-endian, unaligned buffers, fields of structured arrays)
//! is converted once by numpy itself (`astype(float64)` with a fresh, aligned buffer),
//! so no layout can be misread. Non-float dtypes are a `TypeError`: the Python layer
//! converts integers and lists before calling.

use nalgebra::{DMatrix, Point2};
use numpy::ndarray::{ArrayViewD, Ix1, Ix2, IxDyn};
use numpy::{
    PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::{Error, Result};

/// A float64 array read from numpy, borrowed whenever its layout allows.
pub struct Floats<'py> {
    array: PyReadonlyArrayDyn<'py, f64>,
}

impl Floats<'_> {
    /// The data as an ndarray view (any strides).
    pub fn view(&self) -> ArrayViewD<'_, f64> {
        self.array.as_array()
    }

    /// The shape.
    pub fn shape(&self) -> &[usize] {
        self.array.shape()
    }

    /// The data as one C-ordered slice, when the array is C-contiguous. (numpy's own
    /// `as_slice` also accepts Fortran order, whose slice is not in row order.)
    pub fn as_slice(&self) -> Option<&[f64]> {
        if self.array.is_c_contiguous() {
            self.array.as_slice().ok()
        } else {
            None
        }
    }
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "an unknown type".to_owned())
}

/// Reads `obj` (named `name` in errors) as a float64 array of `ndim` dimensions.
pub fn floats<'py>(obj: &Bound<'py, PyAny>, name: &str, ndim: usize) -> Result<Floats<'py>> {
    let untyped = obj.cast::<PyUntypedArray>().map_err(|_| {
        Error::Type(format!(
            "{name} must be a numpy array, got {}",
            type_name(obj)
        ))
    })?;
    if untyped.ndim() != ndim {
        return Err(Error::Value(format!(
            "{name} must be {ndim}-D, got shape {:?}",
            untyped.shape()
        )));
    }
    let dtype = untyped.dtype();
    let py = obj.py();
    if dtype.kind() != b'f' {
        return Err(Error::Type(format!(
            "{name} must have a float64 or float32 dtype, got {dtype}"
        )));
    }
    let aligned = obj
        .getattr("flags")?
        .getattr("aligned")?
        .extract::<bool>()?;
    let array = if aligned && dtype.is_equiv_to(&numpy::dtype::<f64>(py)) {
        obj.clone()
    } else {
        // A fresh buffer from numpy: aligned, native float64, C order.
        obj.call_method1("astype", ("float64",))?
    };
    let typed = array
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| Error::Type(format!("{name}: {e}")))?;
    let array = typed
        .try_readonly()
        .map_err(|e| Error::Value(format!("{name} is being written elsewhere: {e}")))?;
    Ok(Floats { array })
}

/// An (N, 2) or (N, 3) float array seen as planar points (z is carried by the caller).
/// A C-contiguous (N, 2) float64 array is borrowed; anything else is gathered once.
pub enum PointRows<'py> {
    /// The borrowed numpy buffer, flat `[x0, y0, x1, y1, ...]`.
    Borrowed(Floats<'py>),
    /// Gathered copy.
    Owned(Vec<Point2<f64>>),
}

impl PointRows<'_> {
    /// The points, without copying.
    pub fn as_points(&self) -> &[Point2<f64>] {
        match self {
            // Built only for a C-contiguous (N, 2) array, so the slice exists.
            PointRows::Borrowed(a) => bytemuck::cast_slice(a.as_slice().unwrap_or(&[])),
            PointRows::Owned(v) => v,
        }
    }
}

/// Reads `obj` as an (N, 2) or (N, 3) float numpy array named `name`.
pub fn point_rows<'py>(obj: &Bound<'py, PyAny>, name: &str) -> Result<PointRows<'py>> {
    let a = floats(obj, name, 2)?;
    let shape = a.shape().to_vec();
    if !(shape[1] == 2 || shape[1] == 3) {
        return Err(Error::Value(format!(
            "{name} must have shape (N, 2) or (N, 3), got {shape:?}"
        )));
    }
    if shape[1] == 2 && a.as_slice().is_some() {
        return Ok(PointRows::Borrowed(a));
    }
    let view = a
        .view()
        .into_dimensionality::<Ix2>()
        .map_err(|e| Error::Value(e.to_string()))?;
    Ok(PointRows::Owned(
        view.rows()
            .into_iter()
            .map(|r| Point2::new(r[0], r[1]))
            .collect(),
    ))
}

/// Reads a 1-D float array (any strides) into a vector.
pub fn float_vector(obj: &Bound<'_, PyAny>, name: &str) -> Result<Vec<f64>> {
    let a = floats(obj, name, 1)?;
    Ok(match a.as_slice() {
        Some(s) => s.to_vec(),
        None => a
            .view()
            .into_dimensionality::<Ix1>()
            .map_err(|e| Error::Value(e.to_string()))?
            .to_vec(),
    })
}

/// Reads a 2-D float array (any strides) as a matrix.
pub fn matrix(obj: &Bound<'_, PyAny>, name: &str) -> Result<DMatrix<f64>> {
    let a = floats(obj, name, 2)?;
    let v = a
        .view()
        .into_dimensionality::<Ix2>()
        .map_err(|e| Error::Value(e.to_string()))?;
    if v.is_empty() {
        // A (0, 2^40) array holds nothing, but filling it column by column would
        // still walk 2^40 empty columns: a hang outside release builds.
        return Ok(DMatrix::zeros(v.nrows(), v.ncols()));
    }
    Ok(DMatrix::from_fn(v.nrows(), v.ncols(), |i, j| v[(i, j)]))
}

/// Reads a float array of `ndim` dimensions as (shape, C-ordered values).
pub fn tensor(obj: &Bound<'_, PyAny>, name: &str, ndim: usize) -> Result<(Vec<usize>, Vec<f64>)> {
    let a = floats(obj, name, ndim)?;
    let shape = a.shape().to_vec();
    let data = match a.as_slice() {
        Some(s) => s.to_vec(),
        None => a.view().iter().copied().collect(),
    };
    Ok((shape, data))
}

/// A row-major numpy copy of a (column-major) nalgebra matrix.
pub fn to_numpy<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, numpy::PyArray2<f64>> {
    use numpy::IntoPyArray;
    numpy::ndarray::Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)])
        .into_pyarray(py)
}

/// A row-major buffer as an array of the given shape, moved without a copy.
pub fn shaped<'py>(
    py: Python<'py>,
    data: Vec<f64>,
    shape: &[usize],
) -> Result<Bound<'py, numpy::PyArrayDyn<f64>>> {
    use numpy::IntoPyArray;
    numpy::ndarray::ArrayD::from_shape_vec(IxDyn(shape), data)
        .map(|a| a.into_pyarray(py))
        .map_err(|e| Error::Value(format!("internal shape error: {e}")))
}

/// `array` made read-only and owned: a frozen result's arrays are not to be written.
pub fn read_only<T: pyo3::type_object::PyTypeCheck>(array: Bound<'_, T>) -> PyResult<Py<T>> {
    array
        .as_any()
        .getattr("flags")?
        .setattr("writeable", false)?;
    Ok(array.unbind())
}

/// A float array of `shape` from the row-major `data`, read-only.
pub fn frozen_array(
    py: Python<'_>,
    data: Vec<f64>,
    shape: &[usize],
) -> PyResult<Py<PyArrayDyn<f64>>> {
    read_only(shaped(py, data, shape)?)
}

/// One field of every item as a read-only 1-D array: a result's column (the ids,
/// counts or flags of a map's entries).
pub fn column<T, E: numpy::Element>(
    py: Python<'_>,
    items: &[T],
    field: impl Fn(&T) -> E,
) -> PyResult<Py<numpy::PyArray1<E>>> {
    use numpy::IntoPyArray;
    read_only(items.iter().map(field).collect::<Vec<_>>().into_pyarray(py))
}

/// Loads numpy's C API at import. The numpy crate loads it lazily, on the first array,
/// by running Python code, and panics if that code raises; a Ctrl-C that arrived
/// during native work is raised by exactly that code, so a long run interrupted just
/// before it returns its arrays would end in a panic instead of KeyboardInterrupt.
pub fn load_numpy_api(py: Python<'_>) -> PyResult<()> {
    py.import("numpy")?;
    std::panic::catch_unwind(|| {
        numpy::PyArray1::<f64>::zeros(py, 0, false);
    })
    .map_err(|_| pyo3::exceptions::PyImportError::new_err("rperc could not load numpy's C API"))
}
