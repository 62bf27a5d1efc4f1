//! The one place core errors become Python exceptions, and the one helper every heavy call goes
//! through (work on a worker thread with the GIL released, Ctrl-C honoured, panics caught, errors
//! mapped).
//!
//! The exception classes are created here, inside the extension, so the extension never imports
//! the Python package above it; `geomtex` re-exports them. Each subclass also derives from the
//! built-in its users expect to catch (`except ValueError` keeps working for bad input).

use std::ffi::CStr;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::Duration;

use pyo3::exceptions::{PyException, PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

use crate::cancel::{catching_panics, Cancel};
use crate::error::GeomtexError;

/// Which built-in a class also derives from, besides `GeomtexError`.
#[derive(Clone, Copy)]
enum Builtin {
    None,
    Value,
    OS,
    Runtime,
}

/// Name, docstring and built-in base of every subclass of `geomtex.GeomtexError`.
const SUBCLASSES: [(&CStr, &CStr, Builtin); 7] = [
    (
        c"geomtex.MeshError",
        c"The input mesh is unusable: NaN/inf, bad or negative indices, empty, wrong shape/dtype.",
        Builtin::Value,
    ),
    (
        c"geomtex.ParameterError",
        c"A keyword is out of range, of the wrong type, or contradicts another.",
        Builtin::Value,
    ),
    (
        c"geomtex.FormatError",
        c"A file is not a .gtex (or mesh) file, is truncated, corrupt, or of an unknown version.",
        Builtin::Value,
    ),
    (
        c"geomtex.FileError",
        c"A file could not be read or written.",
        Builtin::OS,
    ),
    (
        c"geomtex.CancelledError",
        c"The progress callback returned False.",
        Builtin::None,
    ),
    (
        c"geomtex.DeviceError",
        c"No usable GPU adapter, or the GPU refused a resource.",
        Builtin::Runtime,
    ),
    (
        c"geomtex.InternalError",
        c"A bug in geomtex (a panic caught at the boundary); please report it with its message.",
        Builtin::Runtime,
    ),
];

/// `GeomtexError` first, then `SUBCLASSES` in order.
static CLASSES: PyOnceLock<Vec<Py<PyType>>> = PyOnceLock::new();

fn create_classes(py: Python<'_>) -> PyResult<Vec<Py<PyType>>> {
    let root = PyErr::new_type(
        py,
        c"geomtex.GeomtexError",
        Some(c"Root of every error geomtex raises on purpose."),
        Some(&py.get_type::<PyException>()),
        None,
    )?;
    let mut classes = vec![root.clone_ref(py)];
    for (name, doc, builtin) in SUBCLASSES {
        classes.push(subclass(py, name, doc, builtin, root.bind(py))?);
    }
    Ok(classes)
}

/// `PyErr::new_type` takes one base type; a class with two bases is made by calling `type` the
/// way a `class` statement would.
fn subclass(
    py: Python<'_>,
    name: &CStr,
    doc: &CStr,
    builtin: Builtin,
    root: &Bound<'_, PyType>,
) -> PyResult<Py<PyType>> {
    let name = name.to_str().expect("class names are ASCII");
    let (module, short) = name.rsplit_once('.').expect("class names are qualified");
    let mut bases = vec![root.clone()];
    match builtin {
        Builtin::None => {}
        Builtin::Value => bases.push(py.get_type::<PyValueError>()),
        Builtin::OS => bases.push(py.get_type::<PyOSError>()),
        Builtin::Runtime => bases.push(py.get_type::<PyRuntimeError>()),
    }
    let namespace = PyDict::new(py);
    namespace.set_item("__module__", module)?;
    namespace.set_item("__doc__", doc.to_str().expect("docs are UTF-8"))?;
    let class = py
        .get_type::<PyType>()
        .call1((short, PyTuple::new(py, bases)?, namespace))?;
    Ok(class.cast_into::<PyType>()?.unbind())
}

fn classes(py: Python<'_>) -> &[Py<PyType>] {
    CLASSES
        .get_or_try_init(py, || create_classes(py))
        .expect("creating geomtex's exception classes cannot fail")
}

/// Adds `GeomtexError` and its subclasses to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    for class in classes(m.py()) {
        let class = class.bind(m.py());
        m.add(class.name()?, class)?;
    }
    Ok(())
}

impl From<GeomtexError> for PyErr {
    fn from(e: GeomtexError) -> PyErr {
        let index = match &e {
            // Only reaches Python if a token was set without a signal; raised as Ctrl-C would be.
            GeomtexError::Interrupted(_) => return PyKeyboardInterrupt::new_err(e.to_string()),
            GeomtexError::Mesh(_) => 1,
            GeomtexError::Parameter(_) => 2,
            GeomtexError::Format(_) => 3,
            GeomtexError::Io { .. } => 4,
            GeomtexError::Cancelled(_) => 5,
            GeomtexError::Device(_) => 6,
            GeomtexError::Internal(_) => 7,
        };
        let message = e.to_string();
        Python::attach(|py| PyErr::from_type(classes(py)[index].bind(py).clone(), message))
    }
}

/// A `ParameterError` with `message`.
pub fn parameter_error(message: String) -> PyErr {
    GeomtexError::Parameter(message).into()
}

/// How often the calling thread takes the GIL to look for Ctrl-C (and other signals) while a
/// heavy call runs: well inside the 1 s a user waits for KeyboardInterrupt.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Runs `work` on a worker thread with the GIL released, while this thread takes the GIL every
/// `SIGNAL_POLL` to run Python's signal handlers: when one raises (Ctrl-C: KeyboardInterrupt),
/// the cancel token handed to `work` is set, the worker is awaited (the core's long loops poll
/// the token, so it stops within a fraction of a second) and the handler's exception is raised.
/// A panic inside `work` becomes an `InternalError` naming `what` instead of crossing into
/// Python, and core errors become their exception classes.
pub fn heavy<T: Send>(
    py: Python<'_>,
    what: &str,
    work: impl FnOnce(&Cancel) -> crate::error::Result<T> + Send,
) -> PyResult<T> {
    let cancel = Cancel::new();
    let (sender, receiver) = mpsc::channel();
    std::thread::scope(|scope| {
        let worker = std::thread::Builder::new()
            .name("geomtex-worker".into())
            // As much stack as a main thread gets, where the work ran before.
            .stack_size(8 << 20)
            .spawn_scoped(scope, || {
                let result = catching_panics(what, || work(&cancel));
                let _ = sender.send(result);
            });
        if let Err(e) = worker {
            return Err(GeomtexError::Internal(format!(
                "cannot start a worker thread for {what}: {e}"
            ))
            .into());
        }
        wait_for(py, receiver, &cancel)?.map_err(PyErr::from)
    })
}

/// The worker's result, or the exception a signal handler raised meanwhile (after setting
/// `cancel` and waiting for the worker to stop, so nothing runs on after the call returns).
fn wait_for<R: Send>(py: Python<'_>, receiver: Receiver<R>, cancel: &Cancel) -> PyResult<R> {
    let mut receiver = receiver;
    loop {
        // The receiver travels into the GIL-free closure and back (it is Send, not Sync).
        let (back, got) = py.detach(move || {
            let got = receiver.recv_timeout(SIGNAL_POLL);
            (receiver, got)
        });
        receiver = back;
        match got {
            Ok(result) => return Ok(result),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                return Err(GeomtexError::Internal("a worker thread vanished".into()).into())
            }
        }
        if let Err(signal) = py.check_signals() {
            cancel.cancel();
            py.detach(move || {
                let _ = receiver.recv();
            });
            return Err(signal);
        }
    }
}
