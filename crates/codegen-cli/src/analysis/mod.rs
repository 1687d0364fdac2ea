//! The analyses, one request and one result type each, shared by the command line and
//! Python (the layer between the scenario and the commands): [`frf`] (the frequency
//! response), [`linearize`] (equilibrium and modes), [`stationary`] (the stationary random
//! response), [`eval`] (a mechanism's equations at one state), and [`figures`], the
//! catalogue of every figure a scenario can yield and the constraints on them; [`error`],
//! why an analysis refuses a request ([`AnalysisError`]).
//!
//! Results carry their warnings as data ([`Warning`]): the command line prints them on
//! standard error, Python issues `warnings.warn`. Nothing here prints.

pub mod error;
pub mod eval;
pub mod figures;
pub mod frf;
pub mod linearize;
pub mod optimization;
pub mod stationary;
pub mod sweep;

use serde::Serialize;

pub use error::AnalysisError;

/// A warning of an analysis: what the user should know about a result that is still
/// computed (a peak at an edge of the band, excitations left out).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Warning {
    /// The text, without the file or a `warning:` prefix.
    pub message: String,
    /// The file it is about (the scenario), where known.
    pub file: Option<String>,
    /// The entity it is about (a response, an excitation, a mechanism), where known.
    pub entity: Option<String>,
    /// A note (information) rather than a warning.
    pub note: bool,
}

impl Warning {
    /// A warning about `entity` of `file`.
    pub fn about(file: &str, entity: impl Into<String>, message: impl Into<String>) -> Self {
        Warning {
            message: message.into(),
            file: Some(file.to_string()),
            entity: Some(entity.into()),
            note: false,
        }
    }

    /// A note (no file, no entity).
    pub fn note(message: impl Into<String>) -> Self {
        Warning {
            message: message.into(),
            file: None,
            entity: None,
            note: true,
        }
    }
}

/// The line the command line prints on standard error: `note: MESSAGE`,
/// `warning: FILE: MESSAGE` or `warning: MESSAGE`.
impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.note, &self.file) {
            (true, _) => write!(f, "note: {}", self.message),
            (false, Some(file)) => write!(f, "warning: {file}: {}", self.message),
            (false, None) => write!(f, "warning: {}", self.message),
        }
    }
}
