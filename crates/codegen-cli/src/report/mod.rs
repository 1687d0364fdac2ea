//! Output files of a run: CSV time histories ([`mod@csv`], the `csv` crate) streamed row by
//! row ([`stream`]), typed JSON summaries ([`summary`]) and the SVG plot ([`plot`],
//! plotters) of what the run kept in bounded memory ([`digest`]), all committed together by
//! the one atomic writer ([`writer`]).

pub mod csv;
pub mod digest;
pub mod hybrid;
pub mod plot;
pub mod rows;
pub mod stream;
pub mod summary;
pub mod writer;

pub use stream::StreamFile;
pub use writer::{OutputFile, WriteError, commit, commit_files};

/// An output that could not be produced.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A CSV could not be formatted.
    #[error(transparent)]
    Csv(#[from] ::csv::Error),
    /// A summary could not be formatted.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] plot::PlotError),
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
}
