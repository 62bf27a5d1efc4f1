//! numpy in and out: row-major arrays built from the core's flat vectors without copying them
//! again (`into_pyarray` takes ownership of the buffer), and 4x4 matrices in numpy's row order.

use glam::DMat4;
use numpy::ndarray::{Array2, Array3, Dimension};
use numpy::{
    Element, IntoPyArray, PyArray2, PyArray3, PyReadonlyArray, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::error::GeomtexError;

/// Two arrays returned together, as a Python tuple.
pub type ArrayPair<'py, A, B> = PyResult<(Bound<'py, A>, Bound<'py, B>)>;

/// (rows, columns) array over a flat row-major vector.
pub fn matrix<T: Element>(
    py: Python<'_>,
    flat: Vec<T>,
    rows: usize,
    cols: usize,
) -> Bound<'_, PyArray2<T>> {
    Array2::from_shape_vec((rows, cols), flat)
        .expect("the core's vector has rows x cols elements")
        .into_pyarray(py)
}

/// (height, width, channels) array over a flat row-major vector.
pub fn image<T: Element>(
    py: Python<'_>,
    flat: Vec<T>,
    shape: (usize, usize, usize),
) -> Bound<'_, PyArray3<T>> {
    Array3::from_shape_vec(shape, flat)
        .expect("the core's vector has height x width x channels elements")
        .into_pyarray(py)
}

/// (N, K) array of fixed-size rows.
pub fn rows<'py, T: Element + Copy, const K: usize>(
    py: Python<'py>,
    items: &[[T; K]],
) -> Bound<'py, PyArray2<T>> {
    matrix(
        py,
        items.iter().flatten().copied().collect(),
        items.len(),
        K,
    )
}

/// A C-ordered copy of an array's elements.
pub fn flat<T: Element + Clone, D: Dimension>(a: &PyReadonlyArray<'_, T, D>) -> Vec<T> {
    a.as_array()
        .as_standard_layout()
        .into_owned()
        .into_raw_vec_and_offset()
        .0
}

/// Checks that `a` has `cols` columns; `what` names it in the error, raised as `kind`.
pub fn expect_columns<T: Element>(
    a: &PyReadonlyArray2<'_, T>,
    cols: usize,
    what: &str,
    kind: fn(String) -> GeomtexError,
) -> PyResult<()> {
    if a.shape()[1] == cols {
        return Ok(());
    }
    Err(kind(format!(
        "{what} must have shape (N, {cols}); got {:?}",
        a.shape()
    ))
    .into())
}

/// A 4x4 matrix as numpy's row-major (4, 4) float64.
pub fn mat4_to_numpy(py: Python<'_>, m: DMat4) -> Bound<'_, PyArray2<f64>> {
    matrix(py, m.transpose().to_cols_array().to_vec(), 4, 4)
}
