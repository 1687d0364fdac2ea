//! Rows formatted and written by a helper thread: [`PipedRows`] takes a run's rows of
//! numbers in batches and hands them to a thread that owns the [`RowSink`] (the CSV writer
//! and its file), so that the shortest round-trip formatting of every number (about 300
//! instructions each: a third of the paper's damper run's instructions outside the steps)
//! and the writes run on another core while the run steps on. The file's bytes are those
//! the sink writes alone, row after row in order. When the rows are over, the thread ends
//! the sink ([`RowSink::end`]: a streamed file flushed and its data synced in the
//! background) while the caller makes its other outputs.
//!
//! Batches are recycled (a bounded number in flight: a sink slower than the run, a slow
//! disk, holds the run back instead of filling the memory). An error of the sink (a full
//! disk) ends the thread; the run sees it at its next batch, or at [`PipedRows::into_inner`].
//! Dropping a `PipedRows` (a failed run) tells the thread to leave the rows still queued and
//! waits for it, so that the sink (a [`super::StreamFile`] removing its temporary file when
//! dropped) is gone when it is.
//! Where no thread can be started (or a row has no cell), the rows go to the sink directly.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

use super::rows::RowSink;

/// Rows in a batch.
const BATCH_ROWS: usize = 256;

/// Batches on their way to the thread, at most (one more being formatted, one filling).
const IN_FLIGHT: usize = 2;

/// A row sink whose rows another thread writes into `S` (see the module documentation).
pub struct PipedRows<S: RowSink + Send + 'static> {
    columns: usize,
    rows: u64,
    /// The sink written on this thread (no helper thread).
    direct: Option<S>,
    /// The rows being filled, `columns` numbers each.
    batch: Vec<f64>,
    /// Full batches to the thread (`None` once finished).
    to_sink: Option<SyncSender<Vec<f64>>>,
    /// Emptied batches back from the thread.
    spare: Receiver<Vec<f64>>,
    /// The thread: the sink, or the sink's first error.
    worker: Option<JoinHandle<Result<S, csv::Error>>>,
    /// The error met by [`PipedRows::close`], for [`PipedRows::into_inner`].
    failed: Option<csv::Error>,
    /// Set when dropped: the thread leaves the rows still queued (and does not end the sink).
    abandoned: Arc<AtomicBool>,
}

impl<S: RowSink + Send + 'static> PipedRows<S> {
    /// Rows of `columns` numbers for `sink`, on a helper thread (directly when there is no
    /// cell or no thread).
    pub fn new(sink: S, columns: usize) -> PipedRows<S> {
        match Self::threaded(sink, columns) {
            Ok(piped) => piped,
            Err(sink) => {
                let (_, spare) = sync_channel(0);
                PipedRows {
                    columns,
                    rows: 0,
                    direct: Some(sink),
                    batch: Vec::new(),
                    to_sink: None,
                    spare,
                    worker: None,
                    failed: None,
                    abandoned: Arc::default(),
                }
            }
        }
    }

    fn threaded(sink: S, columns: usize) -> Result<PipedRows<S>, S> {
        if columns == 0 {
            return Err(sink);
        }
        let (to_sink, batches) = sync_channel::<Vec<f64>>(IN_FLIGHT);
        let (give_back, spare) = sync_channel::<Vec<f64>>(IN_FLIGHT + 2);
        // The sink moves to the thread only once it runs: a failed spawn gives it back.
        let (start, started) = sync_channel::<S>(1);
        let abandoned = Arc::new(AtomicBool::new(false));
        let dropped = Arc::clone(&abandoned);
        let spawned = std::thread::Builder::new()
            .name("rows".into())
            .spawn(move || {
                let mut sink = started.recv().map_err(|_| {
                    csv::Error::from(std::io::Error::other("the rows' thread got no sink"))
                })?;
                while let Ok(mut batch) = batches.recv() {
                    if dropped.load(Ordering::SeqCst) {
                        return Ok(sink);
                    }
                    for row in batch.chunks_exact(columns) {
                        sink.write_row(row)?;
                    }
                    batch.clear();
                    // Full or gone: the batch is dropped instead.
                    let _ = give_back.try_send(batch);
                }
                if !dropped.load(Ordering::SeqCst) {
                    sink.end()?;
                }
                Ok(sink)
            });
        let worker = match spawned {
            Ok(handle) => handle,
            Err(_) => return Err(sink),
        };
        if let Err(returned) = start.send(sink) {
            // The thread ended before taking it (it cannot, but the sink is not lost).
            let _ = worker.join();
            return Err(returned.0);
        }
        Ok(PipedRows {
            columns,
            rows: 0,
            direct: None,
            batch: Vec::with_capacity(BATCH_ROWS * columns),
            to_sink: Some(to_sink),
            spare,
            worker: Some(worker),
            failed: None,
            abandoned,
        })
    }

    /// Sends the rows filled so far; the sink's error if the thread has stopped on one.
    fn send(&mut self) -> Result<(), csv::Error> {
        if self.batch.is_empty() {
            return Ok(());
        }
        let next = self
            .spare
            .try_recv()
            .unwrap_or_else(|_| Vec::with_capacity(BATCH_ROWS * self.columns));
        let full = std::mem::replace(&mut self.batch, next);
        let sent = match &self.to_sink {
            Some(tx) => tx.send(full).is_ok(),
            None => false,
        };
        if sent {
            Ok(())
        } else {
            // The thread has ended: on the sink's error.
            Err(self.join().err().unwrap_or_else(|| {
                csv::Error::from(std::io::Error::other("the rows' thread ended early"))
            }))
        }
    }

    /// Ends the thread (after the batches sent) and takes its result.
    fn join(&mut self) -> Result<S, csv::Error> {
        self.to_sink = None;
        match self.worker.take() {
            Some(handle) => handle.join().unwrap_or_else(|_| {
                Err(csv::Error::from(std::io::Error::other(
                    "the rows' thread panicked",
                )))
            }),
            None => Err(csv::Error::from(std::io::Error::other(
                "the rows' thread has been joined",
            ))),
        }
    }

    /// Sends the last rows and lets the thread finish them (while the caller does other
    /// work): no row may follow. An error is kept for [`PipedRows::into_inner`].
    pub fn close(&mut self) {
        let ended = match &mut self.direct {
            Some(sink) => sink.end(),
            None => self.send(),
        };
        if let Err(e) = ended {
            self.failed = Some(e);
        }
        self.to_sink = None;
    }

    /// The sink, every row written into it ([`RowSink::end`] called when the rows went
    /// through the thread or [`PipedRows::close`] was called).
    pub fn into_inner(mut self) -> Result<S, csv::Error> {
        if let Some(e) = self.failed.take() {
            return Err(e);
        }
        if let Some(sink) = self.direct.take() {
            return Ok(sink);
        }
        self.send()?;
        self.join()
    }
}

impl<S: RowSink + Send + 'static> RowSink for PipedRows<S> {
    fn write_row(&mut self, cells: &[f64]) -> Result<(), csv::Error> {
        assert_eq!(cells.len(), self.columns, "PipedRows: one cell per column");
        self.rows += 1;
        if let Some(sink) = &mut self.direct {
            return sink.write_row(cells);
        }
        self.batch.extend_from_slice(cells);
        if self.batch.len() >= BATCH_ROWS * self.columns {
            self.send()?;
        }
        Ok(())
    }

    fn rows(&self) -> u64 {
        self.rows
    }
}

impl<S: RowSink + Send + 'static> Drop for PipedRows<S> {
    /// Tells the thread to stop and waits for it, which drops the sink (see the module
    /// documentation).
    fn drop(&mut self) {
        if self.worker.is_some() {
            self.abandoned.store(true, Ordering::SeqCst);
            let _ = self.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};

    use super::*;
    use crate::report::rows::CsvRows;

    fn header(columns: usize) -> Vec<String> {
        (0..columns).map(|c| format!("c{c}")).collect()
    }

    fn row(r: usize, columns: usize) -> Vec<f64> {
        (0..columns)
            .map(|c| match (r + c) % 5 {
                0 => f64::NAN,
                1 => -0.0,
                _ => (r as f64 + 0.1) * 1.7f64.powi(c as i32 - 3),
            })
            .collect()
    }

    /// Every count of rows around the batches' size: the piped CSV is the direct one, byte
    /// for byte.
    #[test]
    fn piped_rows_are_the_rows_written_directly() {
        for columns in [1, 3, 24] {
            for n in [
                0,
                1,
                BATCH_ROWS - 1,
                BATCH_ROWS,
                BATCH_ROWS + 1,
                7 * BATCH_ROWS + 13,
            ] {
                let mut direct = CsvRows::new(Vec::new(), &header(columns)).unwrap();
                let csv = CsvRows::new(Vec::new(), &header(columns)).unwrap();
                let mut piped = PipedRows::new(csv, columns);
                assert!(piped.worker.is_some() && piped.direct.is_none());
                for r in 0..n {
                    direct.write_row(&row(r, columns)).unwrap();
                    piped.write_row(&row(r, columns)).unwrap();
                }
                assert_eq!(piped.rows(), n as u64);
                if n % 2 == 1 {
                    piped.close();
                }
                let piped = piped.into_inner().unwrap();
                assert_eq!(piped.rows(), n as u64);
                assert_eq!(
                    piped.into_inner().unwrap(),
                    direct.into_inner().unwrap(),
                    "{columns} columns, {n} rows"
                );
            }
        }
    }

    /// A sink failing at its 300th row: the error reaches the run (at a later batch or at
    /// the end), never a panic or a hang.
    #[test]
    fn the_sinks_error_reaches_the_run() {
        struct Failing(u64);
        impl RowSink for Failing {
            fn write_row(&mut self, _: &[f64]) -> Result<(), csv::Error> {
                self.0 += 1;
                if self.0 == 300 {
                    return Err(std::io::Error::other("disk full").into());
                }
                Ok(())
            }
            fn rows(&self) -> u64 {
                self.0
            }
        }
        for (n, close) in [(400, false), (400, true), (5_000, false)] {
            let mut piped = PipedRows::new(Failing(0), 2);
            let mut first = None;
            for r in 0..n {
                if let Err(e) = piped.write_row(&row(r, 2)) {
                    first = Some(e.to_string());
                    break;
                }
            }
            let e = match first {
                Some(e) => e,
                None => {
                    if close {
                        piped.close();
                    }
                    piped.into_inner().err().expect("an error").to_string()
                }
            };
            assert!(e.contains("disk full"), "{n} rows: {e}");
        }
    }

    /// Dropping the rows (a failed run) waits for the thread, which drops the sink without
    /// ending it; closed rows end it.
    #[test]
    fn dropped_rows_drop_the_sink_before_returning() {
        struct Flagged {
            dropped: Arc<AtomicBool>,
            ended: Arc<AtomicBool>,
        }
        impl RowSink for Flagged {
            fn write_row(&mut self, _: &[f64]) -> Result<(), csv::Error> {
                std::thread::sleep(std::time::Duration::from_micros(50));
                Ok(())
            }
            fn rows(&self) -> u64 {
                0
            }
            fn end(&mut self) -> Result<(), csv::Error> {
                self.ended.store(true, Ordering::SeqCst);
                Ok(())
            }
        }
        impl Drop for Flagged {
            fn drop(&mut self) {
                self.dropped.store(true, Ordering::SeqCst);
            }
        }
        for close in [false, true] {
            let (dropped, ended) = (
                Arc::new(AtomicBool::new(false)),
                Arc::new(AtomicBool::new(false)),
            );
            let sink = Flagged {
                dropped: dropped.clone(),
                ended: ended.clone(),
            };
            let mut piped = PipedRows::new(sink, 1);
            for r in 0..3 * BATCH_ROWS {
                piped.write_row(&[r as f64]).unwrap();
            }
            if close {
                piped.close();
                drop(piped.into_inner().unwrap());
            } else {
                drop(piped);
            }
            assert!(dropped.load(Ordering::SeqCst));
            assert_eq!(ended.load(Ordering::SeqCst), close);
        }
    }

    /// Rows without a cell go to the sink directly (as `""` lines).
    #[test]
    fn rows_without_cells_are_written_directly() {
        let csv = CsvRows::new(Vec::new(), &[]).unwrap();
        let mut piped = PipedRows::new(csv, 0);
        assert!(piped.direct.is_some() && piped.worker.is_none());
        piped.write_row(&[]).unwrap();
        let bytes = piped.into_inner().unwrap().into_inner().unwrap();
        assert_eq!(bytes, b"\"\"\n\"\"\n");
    }
}
