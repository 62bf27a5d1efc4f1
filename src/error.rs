//! One error enum for the whole core. The binding layer maps each variant to one Python exception
//! class (`geomtex.MeshError`, ...), all under `geomtex.GeomtexError`.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum GeomtexError {
    /// The input mesh is unusable (NaN, bad indices, empty, wrong sizes).
    #[error("{0}")]
    Mesh(String),
    /// A keyword or parameter is out of range or contradicts another.
    #[error("{0}")]
    Parameter(String),
    /// A .gtex file is not one, is truncated, corrupt, or of an unknown version.
    #[error("{0}")]
    Format(String),
    /// Reading or writing a file failed.
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: std::io::Error,
    },
    /// No usable GPU adapter, or the GPU refused a resource.
    #[error("{0}")]
    Device(String),
    /// A bug: a panic inside the core, caught before it crossed into Python.
    #[error("{0}")]
    Internal(String),
    /// The progress callback asked to stop.
    #[error("conversion cancelled during stage '{0}'")]
    Cancelled(String),
    /// The caller's cancel token was set (Ctrl-C in Python): the binding layer raises the
    /// signal's own exception (KeyboardInterrupt) in its place.
    #[error("interrupted while {0}")]
    Interrupted(String),
}

pub type Result<T> = std::result::Result<T, GeomtexError>;

/// The value `s` names among `choices` (name, value), or a Parameter error naming `keyword` and
/// every choice ("quality must be 'fast', 'balanced' or 'exact', got \"best\"").
pub fn parse_choice<T: Copy>(keyword: &str, s: &str, choices: &[(&str, T)]) -> Result<T> {
    if let Some(&(_, value)) = choices.iter().find(|(name, _)| *name == s) {
        return Ok(value);
    }
    let names: Vec<String> = choices.iter().map(|(n, _)| format!("'{n}'")).collect();
    let listed = match names.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    };
    Err(GeomtexError::Parameter(format!(
        "{keyword} must be {listed}, got {s:?}"
    )))
}

impl GeomtexError {
    pub fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        GeomtexError::Io {
            context: context.into(),
            source,
        }
    }
}
