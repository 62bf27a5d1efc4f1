//! The Python binding layer (`geomtex._core`): arrays and errors only. Thin wrappers over the
//! core, numpy in and out, heavy work through `errors::heavy` (GIL released, panics caught,
//! errors mapped). It never imports the Python package above it: the package imports this.

mod args;
mod arrays;
mod drawn;
mod errors;
mod gdm;
mod gtex;
mod igt;
mod kinds;
mod mesh;
mod render;
mod set;
mod surfels;

use pyo3::prelude::*;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<mesh::PyMesh>()?;
    m.add_class::<set::PyGeometryTextureSet>()?;
    m.add_function(wrap_pyfunction!(gtex::convert, m)?)?;
    m.add_function(wrap_pyfunction!(gtex::load, m)?)?;
    m.add_class::<surfels::PySurfels>()?;
    m.add_class::<igt::PyIgt>()?;
    m.add_class::<igt::PyIgtMesh>()?;
    m.add_function(wrap_pyfunction!(igt::build_igt, m)?)?;
    m.add_function(wrap_pyfunction!(igt::load_igt, m)?)?;
    m.add_function(wrap_pyfunction!(surfels::load_surfels, m)?)?;
    m.add_class::<gdm::PyGdmVolume>()?;
    m.add_class::<gdm::PyGdmShell>()?;
    m.add_function(wrap_pyfunction!(gdm::gdm_explicit_mesh, m)?)?;
    m.add_class::<render::PyCamera>()?;
    m.add_class::<render::PyScene>()?;
    m.add_class::<render::PyRenderer>()?;
    m.add_class::<render::PyFrame>()?;
    m.add_function(wrap_pyfunction!(render::device_counts, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
