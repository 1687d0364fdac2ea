//! Output files of a damper run: the CSV time history, the JSON summary and an SVG plot of
//! the tip displacement with and without the generator.
//!
//! Every file is written completely or not at all: the content goes to a temporary file in
//! the target directory, which is renamed over the final name only once everything has been
//! written ([`commit_files`]); an interrupted run leaves no half-written file under a final
//! name.

use std::io::Write;
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use serde::Serialize;

use crate::study::Sample;

/// A file prepared in memory, to be committed with [`commit_files`].
#[derive(Clone, Debug)]
pub struct OutputFile {
    /// Final path.
    pub path: PathBuf,
    /// Content.
    pub bytes: Vec<u8>,
}

/// The CSV time history: a header naming every column, one row per sample.
pub fn csv_bytes(samples: &[Sample]) -> Result<Vec<u8>, String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for s in samples {
        w.serialize(s).map_err(|e| e.to_string())?;
    }
    w.into_inner().map_err(|e| e.to_string())
}

/// Pretty-printed JSON of any serialisable summary.
pub fn json_bytes<T: Serialize>(value: &T) -> Result<Vec<u8>, String> {
    let mut v = serde_json::to_vec_pretty(value).map_err(|e| e.to_string())?;
    v.push(b'\n');
    Ok(v)
}

/// SVG plot of the tip displacement (mm) against time for each labelled series (the first
/// on top).
pub fn plot_svg(title: &str, series: &[(&str, &[Sample])]) -> Result<Vec<u8>, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let t_end = series
            .iter()
            .filter_map(|(_, s)| s.last().map(|x| x.t))
            .fold(0.0, f64::max)
            .max(1e-9);
        let ymax = series
            .iter()
            .flat_map(|(_, s)| s.iter().map(|x| x.tip_displacement.abs() * 1e3))
            .fold(0.0, f64::max)
            .max(1e-9)
            * 1.05;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_end, -ymax..ymax)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .y_desc("tip displacement (mm)")
            .draw()
            .map_err(|e| e.to_string())?;
        let colors = [
            RGBColor(200, 30, 30),
            RGBColor(30, 80, 200),
            RGBColor(20, 140, 60),
        ];
        // Drawn last to first, so that the first series is on top.
        for (k, (label, samples)) in series.iter().enumerate().rev() {
            let color = colors[k % colors.len()];
            chart
                .draw_series(LineSeries::new(
                    samples.iter().map(|s| (s.t, s.tip_displacement * 1e3)),
                    color.stroke_width(1),
                ))
                .map_err(|e| e.to_string())?
                .label(*label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg.into_bytes())
}

/// Writes all files atomically as a set: each to a temporary file next to its final name,
/// then renames them. On any error the temporary files are removed and no final name is
/// touched before every file has been written.
pub fn commit_files(files: &[OutputFile]) -> Result<(), String> {
    let tmp_of = |p: &Path| {
        let mut name = p.file_name().map(|n| n.to_os_string()).unwrap_or_default();
        name.push(format!(".tmp-{}", std::process::id()));
        p.with_file_name(name)
    };
    let mut written: Vec<PathBuf> = vec![];
    let cleanup = |written: &[PathBuf]| {
        for t in written {
            let _ = std::fs::remove_file(t);
        }
    };
    for f in files {
        let tmp = tmp_of(&f.path);
        let res = std::fs::File::create(&tmp).and_then(|mut file| {
            file.write_all(&f.bytes)?;
            file.sync_all()
        });
        if let Err(e) = res {
            cleanup(&written);
            let _ = std::fs::remove_file(&tmp);
            return Err(format!("{}: {e}", f.path.display()));
        }
        written.push(tmp);
    }
    for (f, tmp) in files.iter().zip(&written) {
        if let Err(e) = std::fs::rename(tmp, &f.path) {
            cleanup(&written);
            return Err(format!("{}: {e}", f.path.display()));
        }
    }
    Ok(())
}
