//! numpy in: dtype and shape checks, borrowing the buffer when its layout allows.

use nalgebra::Point2;
use numpy::{
    PyArrayDescrMethods, PyArrayMethods, PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::{Error, Result};

/// An (N, 2) or (N, 3) float array seen as planar points (z is carried by the caller).
/// A C-contiguous float64 (N, 2) array is borrowed as is; anything else (float32,
/// strided, N x 3) is gathered into one owned buffer.
pub enum PointRows<'py> {
    /// Borrowed numpy buffer, flat `[x0, y0, x1, y1, ...]`.
    Borrowed(PyReadonlyArray2<'py, f64>),
    /// Gathered copy.
    Owned(Vec<Point2<f64>>),
}

impl PointRows<'_> {
    /// The points, without copying.
    pub fn as_points(&self) -> &[Point2<f64>] {
        match self {
            // Contiguity and the (N, 2) shape were checked when this was built.
            PointRows::Borrowed(a) => bytemuck::cast_slice(a.as_slice().unwrap_or(&[])),
            PointRows::Owned(v) => v,
        }
    }
}

/// Reads `obj` as an (N, 2) or (N, 3) float64/float32 numpy array named `name`.
pub fn point_rows<'py>(obj: &Bound<'py, PyAny>, name: &str) -> Result<PointRows<'py>> {
    let untyped = obj.cast::<PyUntypedArray>().map_err(|_| {
        Error::Type(format!(
            "{name} must be a numpy array, got {}",
            type_name(obj)
        ))
    })?;
    let shape = untyped.shape();
    if shape.len() != 2 || !(shape[1] == 2 || shape[1] == 3) {
        return Err(Error::Value(format!(
            "{name} must have shape (N, 2) or (N, 3), got {shape:?}"
        )));
    }
    let dtype = untyped.dtype();
    let py = obj.py();
    if dtype.is_equiv_to(&numpy::dtype::<f64>(py)) {
        let a = readonly::<f64, numpy::Ix2>(obj)?;
        if shape[1] == 2 && a.is_c_contiguous() {
            return Ok(PointRows::Borrowed(a));
        }
        let view = a.as_array();
        return Ok(PointRows::Owned(
            view.rows()
                .into_iter()
                .map(|r| Point2::new(r[0], r[1]))
                .collect(),
        ));
    }
    if dtype.is_equiv_to(&numpy::dtype::<f32>(py)) {
        let a = readonly::<f32, numpy::Ix2>(obj)?;
        let view = a.as_array();
        return Ok(PointRows::Owned(
            view.rows()
                .into_iter()
                .map(|r| Point2::new(f64::from(r[0]), f64::from(r[1])))
                .collect(),
        ));
    }
    Err(Error::Type(format!(
        "{name} must have a float64 or float32 dtype, got {}",
        dtype
    )))
}

/// Reads a 1-D float64 or float32 array (any strides) into a vector.
pub fn float_vector(obj: &Bound<'_, PyAny>, name: &str) -> Result<Vec<f64>> {
    let untyped = obj.cast::<PyUntypedArray>().map_err(|_| {
        Error::Type(format!(
            "{name} must be a numpy array, got {}",
            type_name(obj)
        ))
    })?;
    if untyped.ndim() != 1 {
        return Err(Error::Value(format!(
            "{name} must be 1-D, got shape {:?}",
            untyped.shape()
        )));
    }
    let py = obj.py();
    let dtype = untyped.dtype();
    if dtype.is_equiv_to(&numpy::dtype::<f64>(py)) {
        let a = readonly::<f64, numpy::Ix1>(obj)?;
        return Ok(match a.as_slice() {
            Ok(slice) => slice.to_vec(),
            Err(_) => a.as_array().to_vec(),
        });
    }
    if dtype.is_equiv_to(&numpy::dtype::<f32>(py)) {
        let a = readonly::<f32, numpy::Ix1>(obj)?;
        return Ok(a.as_array().iter().map(|&v| f64::from(v)).collect());
    }
    Err(Error::Type(format!(
        "{name} must have a float64 or float32 dtype, got {dtype}"
    )))
}

/// Reads a 2-D float array (float64 or float32, any strides) as a matrix.
pub fn matrix(obj: &Bound<'_, PyAny>, name: &str) -> Result<nalgebra::DMatrix<f64>> {
    let untyped = obj.cast::<PyUntypedArray>().map_err(|_| {
        Error::Type(format!(
            "{name} must be a numpy array, got {}",
            type_name(obj)
        ))
    })?;
    if untyped.ndim() != 2 {
        return Err(Error::Value(format!(
            "{name} must be 2-D, got shape {:?}",
            untyped.shape()
        )));
    }
    let py = obj.py();
    let dtype = untyped.dtype();
    if dtype.is_equiv_to(&numpy::dtype::<f64>(py)) {
        let a = readonly::<f64, numpy::Ix2>(obj)?;
        let v = a.as_array();
        return Ok(nalgebra::DMatrix::from_fn(v.nrows(), v.ncols(), |i, j| {
            v[(i, j)]
        }));
    }
    if dtype.is_equiv_to(&numpy::dtype::<f32>(py)) {
        let a = readonly::<f32, numpy::Ix2>(obj)?;
        let v = a.as_array();
        return Ok(nalgebra::DMatrix::from_fn(v.nrows(), v.ncols(), |i, j| {
            f64::from(v[(i, j)])
        }));
    }
    Err(Error::Type(format!(
        "{name} must have a float64 or float32 dtype, got {dtype}"
    )))
}

/// A row-major numpy copy of a (column-major) nalgebra matrix.
pub fn to_numpy<'py>(
    py: Python<'py>,
    m: &nalgebra::DMatrix<f64>,
) -> Bound<'py, numpy::PyArray2<f64>> {
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
    numpy::ndarray::ArrayD::from_shape_vec(shape.to_vec(), data)
        .map(|a| a.into_pyarray(py))
        .map_err(|e| Error::Value(format!("internal shape error: {e}")))
}

/// A read-only borrow of a typed array whose dtype was already checked.
fn readonly<'py, T, D>(obj: &Bound<'py, PyAny>) -> Result<numpy::PyReadonlyArray<'py, T, D>>
where
    T: numpy::Element,
    D: numpy::ndarray::Dimension,
{
    let typed = obj
        .cast::<numpy::PyArray<T, D>>()
        .map_err(|e| Error::Type(e.to_string()))?;
    typed
        .try_readonly()
        .map_err(|e| Error::Value(format!("array is being written elsewhere: {e}")))
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "an unknown type".to_owned())
}
