//! Arguments converted once at the boundary: whatever numpy and trimesh users pass (lists,
//! tuples, numpy arrays of any real dtype, numpy scalars) becomes the core's f64/i64/str, and
//! anything else — a wrong type, an integer out of range, a ragged list — is a `ParameterError`
//! naming the argument and its value. PyO3's own extraction would raise TypeError or
//! OverflowError instead, so public methods take `&Bound<PyAny>` and call these.

use std::ops::RangeInclusive;
use std::path::PathBuf;

use glam::{DMat4, DVec3};
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyString};

use super::errors::parameter_error;

/// Most rays or pixels one call produces: 2^26 (8192 x 8192), 3.2 GB of float64 rays.
pub const MAX_RAYS: u64 = 1 << 26;

/// Longest image side the renderer and `Camera.rays` accept (wgpu's common texture limit).
pub const MAX_IMAGE_SIDE: i64 = 16384;

/// `repr(obj)`, shortened so a huge array does not flood the message.
fn shown(obj: &Bound<'_, PyAny>) -> String {
    let text = obj
        .repr()
        .map(|r| {
            r.to_string()
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_else(|_| "<unprintable>".into());
    if text.chars().count() > 80 {
        format!("{}…", text.chars().take(80).collect::<String>())
    } else {
        text
    }
}

fn wrong(what: &str, wanted: &str, obj: &Bound<'_, PyAny>) -> PyErr {
    parameter_error(format!("{what} must be {wanted}, got {}", shown(obj)))
}

/// Python's and numpy's booleans: integers to Python, but never a count or a size here.
fn is_bool(obj: &Bound<'_, PyAny>) -> bool {
    obj.is_instance_of::<PyBool>() || obj.get_type().name().is_ok_and(|n| n == "bool")
}

/// A real number: int, float, numpy scalar or 0-d array (not bool, not str).
pub fn real(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<f64> {
    if is_bool(obj) || obj.is_instance_of::<PyString>() {
        return Err(wrong(what, "a number", obj));
    }
    obj.extract::<f64>()
        .map_err(|_| wrong(what, "a number", obj))
}

/// `real` for an optional keyword.
pub fn opt_real(obj: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Option<f64>> {
    obj.map(|o| real(o, what)).transpose()
}

/// An integer (Python int or numpy integer, not bool, not a float) within `range`.
pub fn integer(obj: &Bound<'_, PyAny>, what: &str, range: RangeInclusive<i64>) -> PyResult<i64> {
    let wanted = || match (*range.start(), *range.end()) {
        (i64::MIN, i64::MAX) => "an integer".to_string(),
        (lo, hi) => format!("an integer in [{lo}, {hi}]"),
    };
    if is_bool(obj) {
        return Err(wrong(what, &wanted(), obj));
    }
    let index = obj
        .py()
        .import("operator")?
        .call_method1("index", (obj,))
        .map_err(|_| wrong(what, &wanted(), obj))?;
    match index.extract::<i64>() {
        Ok(v) if range.contains(&v) => Ok(v),
        _ => Err(wrong(what, &wanted(), obj)),
    }
}

/// `integer` for an optional keyword.
pub fn opt_integer(
    obj: Option<&Bound<'_, PyAny>>,
    what: &str,
    range: RangeInclusive<i64>,
) -> PyResult<Option<i64>> {
    obj.map(|o| integer(o, what, range)).transpose()
}

/// An optional `integer` in `range` as u32 (every range given here fits).
pub fn opt_u32(
    obj: Option<&Bound<'_, PyAny>>,
    what: &str,
    range: RangeInclusive<i64>,
) -> PyResult<Option<u32>> {
    Ok(opt_integer(obj, what, range)?.map(|v| v as u32))
}

/// A str keyword (its meaning is parsed by the core, which names the choices).
pub fn opt_text(obj: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Option<String>> {
    obj.map(|o| {
        o.cast::<PyString>()
            .map(|s| s.to_string())
            .map_err(|_| wrong(what, "a str", o))
    })
    .transpose()
}

/// A bool keyword (Python or numpy bool).
pub fn opt_flag(obj: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Option<bool>> {
    obj.map(|o| {
        if is_bool(o) {
            o.is_truthy()
        } else {
            Err(wrong(what, "True or False", o))
        }
    })
    .transpose()
}

/// A file path: str or os.PathLike.
pub fn path(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<PathBuf> {
    obj.extract::<PathBuf>()
        .map_err(|_| wrong(what, "a str or os.PathLike path", obj))
}

/// An array-like of real numbers (any int/uint/float dtype, lists, tuples) as a C-ordered
/// float64 numpy array of `shape` (`None` = any length); bool, complex, strings and ragged
/// lists are refused.
pub fn real_array<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    shape: &[Option<usize>],
) -> PyResult<Bound<'py, PyAny>> {
    let np = obj.py().import("numpy")?;
    let wanted = shape
        .iter()
        .map(|d| d.map_or("N".to_string(), |n| n.to_string()))
        .collect::<Vec<_>>()
        .join(", ");
    let wanted = format!("an array of real numbers of shape ({wanted})");
    let a = np
        .call_method1("asarray", (obj,))
        .map_err(|_| wrong(what, &wanted, obj))?;
    let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
    let dims: Vec<usize> = a.getattr("shape")?.extract()?;
    let fits = dims.len() == shape.len()
        && dims
            .iter()
            .zip(shape)
            .all(|(d, s)| s.is_none_or(|s| *d == s));
    if !"fiu".contains(kind.as_str()) || kind.is_empty() || !fits {
        return Err(wrong(what, &wanted, obj));
    }
    np.call_method1("ascontiguousarray", (a, np.getattr("float64")?))
}

/// The elements of a `real_array` result, read through numpy's buffer (a million rays through
/// `tolist` took most of a ray query's time on a real GPU).
fn real_values(a: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let a: PyReadonlyArrayDyn<'_, f64> = a.extract()?;
    Ok(super::arrays::flat(&a))
}

/// Rays from (N, 3) array-likes of origins and directions of the same shape, each origin finite
/// and each direction finite and non-zero (the first bad one named, origins first). The numpy
/// buffers are read once, with no intermediate copies (a million rays' copies and checks were
/// a fifth of a CPU query).
pub fn rays(
    origins: &Bound<'_, PyAny>,
    directions: &Bound<'_, PyAny>,
) -> PyResult<Vec<(DVec3, DVec3)>> {
    let o = real_array(origins, "origins", &[None, Some(3)])?;
    let d = real_array(directions, "directions", &[None, Some(3)])?;
    let (o, d): (PyReadonlyArrayDyn<'_, f64>, PyReadonlyArrayDyn<'_, f64>) =
        (o.extract()?, d.extract()?);
    if o.shape() != d.shape() {
        return Err(parameter_error(format!(
            "origins and directions must both be (N, 3); got {:?} and {:?}",
            o.shape(),
            d.shape()
        )));
    }
    let (o, d) = (o.as_slice()?, d.as_slice()?);
    let bad_origin = |v: &[f64]| !v.iter().all(|x| x.is_finite());
    let bad_direction = |v: &[f64]| bad_origin(v) || v.iter().all(|&x| x == 0.0);
    if let Some(i) = o.chunks_exact(3).position(bad_origin) {
        return Err(parameter_error(format!(
            "ray {i}: origin {:?} must be finite (origins row {i})",
            &o[3 * i..3 * i + 3]
        )));
    }
    if let Some(i) = d.chunks_exact(3).position(bad_direction) {
        return Err(parameter_error(format!(
            "ray {i}: direction {:?} must be finite and the direction non-zero (directions row {i})",
            &d[3 * i..3 * i + 3]
        )));
    }
    Ok((o.chunks_exact(3).zip(d.chunks_exact(3)))
        .map(|(o, d)| (DVec3::from_slice(o), DVec3::from_slice(d)))
        .collect())
}

/// `real_array` of a fixed shape as a flat row-major vector, every element finite.
fn finite_values(obj: &Bound<'_, PyAny>, what: &str, shape: &[usize]) -> PyResult<Vec<f64>> {
    let dims: Vec<Option<usize>> = shape.iter().map(|&n| Some(n)).collect();
    let values = real_values(&real_array(obj, what, &dims)?)?;
    if values.iter().all(|v| v.is_finite()) {
        Ok(values)
    } else {
        Err(wrong(what, "finite (no NaN or inf)", obj))
    }
}

/// A finite 3-vector from any array-like of 3 reals.
pub fn vec3(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<DVec3> {
    Ok(DVec3::from_slice(&finite_values(obj, what, &[3])?))
}

/// A finite 3x3 matrix, row-major as written.
pub fn mat3(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<[[f64; 3]; 3]> {
    let v = finite_values(obj, what, &[3, 3])?;
    Ok(std::array::from_fn(|r| {
        std::array::from_fn(|c| v[3 * r + c])
    }))
}

/// A finite 4x4 matrix (numpy's row order: column c is a[:, c]); identity when absent.
pub fn mat4(obj: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<DMat4> {
    let Some(obj) = obj else {
        return Ok(DMat4::IDENTITY);
    };
    let v = finite_values(obj, what, &[4, 4])?;
    Ok(DMat4::from_cols_array_2d(&std::array::from_fn(|c| {
        std::array::from_fn(|r| v[4 * r + c])
    })))
}

/// A placement (`mat4`) that is affine and invertible: its last row (0, 0, 0, 1) within 1e-6,
/// its linear part of non-zero determinant. Every kind places its records with the affine part
/// alone, so a projective last row would be drawn differently by different kinds.
pub fn affine_mat4(obj: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<DMat4> {
    let m = mat4(obj, what)?;
    let last = m.row(3);
    if (last - glam::DVec4::W).abs().max_element() > 1e-6 {
        return Err(parameter_error(format!(
            "{what} must be affine (last row 0, 0, 0, 1), got last row {:?}",
            last.to_array()
        )));
    }
    let linear = glam::DMat3::from_mat4(m);
    let scale = [linear.x_axis, linear.y_axis, linear.z_axis]
        .map(|a| a.length())
        .iter()
        .product::<f64>();
    // Finite (mat4 checked), so a NaN cannot reach this test.
    if linear.determinant().abs() <= 1e-12 * scale {
        return Err(parameter_error(format!(
            "{what} must be invertible, but its 3x3 part is singular (determinant {:e})",
            linear.determinant()
        )));
    }
    Ok(m)
}

/// An image size: each side in [1, MAX_IMAGE_SIDE] and at most MAX_RAYS pixels.
pub fn image_size(width: &Bound<'_, PyAny>, height: &Bound<'_, PyAny>) -> PyResult<(u32, u32)> {
    let w = integer(width, "width", 1..=MAX_IMAGE_SIDE)?;
    let h = integer(height, "height", 1..=MAX_IMAGE_SIDE)?;
    if (w * h) as u64 > MAX_RAYS {
        return Err(parameter_error(format!(
            "width x height = {w} x {h} = {} pixels exceeds the limit of {MAX_RAYS} \
             (8192 x 8192)",
            w * h
        )));
    }
    Ok((w as u32, h as u32))
}

/// An RGBA8 color from any array-like of 4 integers in [0, 255].
pub fn rgba8(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<[u8; 4]> {
    let wanted = "four integers in [0, 255] (R, G, B, A)";
    let v = finite_values(obj, what, &[4]).map_err(|_| wrong(what, wanted, obj))?;
    if v.iter()
        .all(|&c| (0.0..=255.0).contains(&c) && c.fract() == 0.0)
    {
        Ok(std::array::from_fn(|i| v[i] as u8))
    } else {
        Err(wrong(what, wanted, obj))
    }
}
