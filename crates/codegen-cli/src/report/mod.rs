//! Output files of a run: CSV time histories ([`mod@csv`], the `csv` crate) streamed row by
//! row ([`stream`], formatted and written on a helper thread by [`pipe`]), typed JSON
//! summaries ([`summary`]) and the SVG plot ([`plot`], plotters) of what the run kept in
//! bounded memory ([`digest`]), all committed together by the one atomic writer
//! ([`writer`]), in an output directory locked for the run ([`lock`]).

pub mod csv;
pub mod digest;
pub mod frf;
pub mod hybrid;
pub mod lock;
pub mod map;
pub mod mechanism;
pub mod op_counts;
pub mod optimize;
pub mod pipe;
pub mod plot;
pub mod random_psd;
pub mod random_run;
pub mod rows;
pub mod shape;
pub mod steady_power;
pub mod stream;
pub mod structure;
pub mod summary;
pub mod sweep;
pub mod writer;

pub use lock::{LockError, OutputLock};
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
    /// The output directory is in use by another run, or cannot be locked.
    #[error(transparent)]
    Lock(#[from] LockError),
    /// A plot could not be drawn: the file, plotters' message.
    #[error("cannot draw {file}: {message}")]
    Draw {
        /// The plot's file name.
        file: &'static str,
        /// Plotters' message.
        message: String,
    },
    /// The results of a sweep do not cover its grid of `points` exactly once.
    #[error("the results do not cover the grid of {points} point(s) exactly once")]
    Uncovered {
        /// The grid's points.
        points: usize,
    },
}

/// A CSV that could not be written to `path`: an I/O error (a full disk) names the file.
pub fn csv_error(path: &std::path::Path, e: ::csv::Error) -> ReportError {
    if !e.is_io_error() {
        return ReportError::Csv(e);
    }
    let error = match e.into_kind() {
        ::csv::ErrorKind::Io(error) => error,
        kind => std::io::Error::other(format!("{kind:?}")),
    };
    ReportError::Write(WriteError {
        what: "write",
        path: path.to_path_buf(),
        error,
    })
}
