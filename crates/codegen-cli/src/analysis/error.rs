//! Why an analysis refuses a request or cannot give its result: one typed error for every
//! analysis of the library ([`AnalysisError`]), with the fields a caller acts on (the
//! argument at fault, the file, the figure and its nearest valid names, the part file of a
//! sweep). The command line prints its text as one line (exit code 2); Python raises the
//! `damper.DamperError` subclass of its kind with the same fields (`crates/damper-py`).
//!
//! The text of each error is the line the command line has always printed: the variants add
//! structure, not new wording.

use crate::analysis::figures::{ConstraintError, UnknownFigure};

/// Why an analysis refuses a request or cannot give its result.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AnalysisError {
    /// An argument of the request outside its range or of the wrong form (`--points 1`,
    /// `--modes 0`, a parameter value that is not a number). `argument` is its command-line
    /// name (`--points`); Python names it by its keyword (`points`).
    #[error("{message}")]
    Argument {
        /// The argument, as the command line spells it (`--points`).
        argument: String,
        /// The whole text.
        message: String,
    },
    /// A name that the scenario or the model does not have: a figure (with the nearest
    /// valid names), an output, a parameter. `what` says which kind of name.
    #[error("{message}")]
    UnknownName {
        /// What kind of name: `figure`, `output`, `parameter`, `objective`.
        what: &'static str,
        /// The name as given (truncated to 80 characters).
        name: String,
        /// The valid names to suggest: for a figure the nearest by edit distance, closest
        /// first (empty where none is near); for a mechanism, coordinate, excitation or model
        /// parameter every valid name (a scenario has few).
        nearest: Vec<String>,
        /// The scenario or model file, where known.
        file: Option<String>,
        /// The whole text.
        message: String,
    },
    /// The scenario (or model) cannot give what was asked: no beam to linearise, no
    /// excitation to respond to, no mode, a kind of scenario the analysis does not take, a
    /// figure that does not exist at a design point.
    #[error("{message}")]
    Unavailable {
        /// The scenario or model file, where known.
        file: Option<String>,
        /// The whole text.
        message: String,
    },
    /// A computation of the analysis failed on this scenario (a singular dynamic stiffness
    /// at a frequency, no static equilibrium for the frequency response).
    #[error("{message}")]
    Numerical {
        /// The scenario file, where known.
        file: Option<String>,
        /// The whole text.
        message: String,
    },
    /// The optimisation problem cannot be posed or solved (no variable, no feasible start).
    #[error("{file}: {error}")]
    Optimization {
        /// The scenario file.
        file: String,
        /// Why.
        error: crate::optimize::OptimizeError,
    },
    /// Sweep part files that cannot be joined (`damper merge`): missing, damaged, of
    /// different sweeps. `path` is the file (or directory) at fault.
    #[error("{message}")]
    Merge {
        /// The part file or the directory at fault.
        path: String,
        /// The whole text.
        message: String,
    },
    /// The machine cannot provide what the analysis needs to start (worker threads, memory
    /// for the grid's index).
    #[error("{message}")]
    Resources {
        /// The whole text.
        message: String,
    },
}

impl AnalysisError {
    /// An argument out of its range: `argument` as the command line spells it, `message` the
    /// whole text.
    pub fn argument(argument: impl Into<String>, message: impl Into<String>) -> Self {
        AnalysisError::Argument {
            argument: argument.into(),
            message: message.into(),
        }
    }

    /// What the scenario `file` cannot give (`message` without the file).
    pub fn unavailable(file: impl Into<String>, message: impl std::fmt::Display) -> Self {
        let file = file.into();
        AnalysisError::Unavailable {
            message: format!("{file}: {message}"),
            file: Some(file),
        }
    }

    /// A failed computation on the scenario `file` (`message` without the file).
    pub fn numerical(file: impl Into<String>, message: impl std::fmt::Display) -> Self {
        let file = file.into();
        AnalysisError::Numerical {
            message: format!("{file}: {message}"),
            file: Some(file),
        }
    }

    /// A part file (or directory) of a sharded sweep that cannot be joined.
    pub fn merge(path: &std::path::Path, message: impl Into<String>) -> Self {
        AnalysisError::Merge {
            path: path.display().to_string(),
            message: message.into(),
        }
    }

    /// An unknown figure, said in `context` (`--map`, `--maximize`, a constraint's text).
    pub fn unknown_figure(context: &str, unknown: &UnknownFigure) -> Self {
        AnalysisError::UnknownName {
            what: "figure",
            name: unknown.name.clone(),
            nearest: unknown.nearest.clone(),
            file: None,
            message: if context.is_empty() {
                unknown.to_string()
            } else {
                format!("{context}: {unknown}")
            },
        }
    }

    /// The scenario or model file the error is about, where known.
    pub fn file(&self) -> Option<&str> {
        match self {
            AnalysisError::UnknownName { file, .. }
            | AnalysisError::Unavailable { file, .. }
            | AnalysisError::Numerical { file, .. } => file.as_deref(),
            AnalysisError::Optimization { file, .. } => Some(file),
            _ => None,
        }
    }
}

impl From<ConstraintError> for AnalysisError {
    fn from(e: ConstraintError) -> Self {
        match &e {
            ConstraintError::Figure { text, unknown } => {
                AnalysisError::unknown_figure(&format!("--constraint {text}"), unknown)
            }
            ConstraintError::Syntax { .. } => {
                AnalysisError::argument("--constraint", e.to_string())
            }
        }
    }
}
