//! `[structure]` (issue #30): a model from another finite-element program as the host. The
//! bundled two-damper beam written out as Matrix Market files (its banded mass, damping and
//! stiffness, nodes with `uy`, `rz` equations) and run as a `kind = "matrices"` structure,
//! unreduced and reduced by Craig–Bampton with every fixed-interface mode, gives the beam's
//! time history; bad `[structure]` input is refused in one line naming the file and entity.

use std::fmt::Write as _;
use std::path::Path;

use codegen_cli::scenario::HybridScenario;

use crate::common::{assert_bad_input, damper, root};

/// The host-independent part of the scenario: the two dampers of `scenarios/two_dampers.toml`,
/// pinned at `left` and `right` (an `x = ...` or `node = ...` line each), a harmonic force at
/// `load`, 0.15 s.
pub(crate) fn scenario(host: &str, left: &str, right: &str, load: &str) -> String {
    let models = root().join("models/double_bar.toml");
    let mut s = format!("kind = \"hybrid\"\n{host}\n");
    for (name, at) in [("left", left), ("right", right)] {
        write!(
            s,
            "[[mechanism]]\nname = \"{name}\"\nmodel = {:?}\nplacement = {{ attachment = \"{name}_pin\", half_angle_deg = 10.0 }}\nmax_condition = 1e4\n\
             [[attachment]]\nname = \"{name}_pin\"\nmechanism = \"{name}\"\npoint = \"tip\"\nkind = \"pin\"\n{at}\n\
             [[force]]\nname = \"gen_{name}\"\nmechanism = \"{name}\"\njoint = \"crank\"\nkind = \"generator\"\nkt = 0.0235\nke = 0.0235\n\
             armature_resistance = 1.5\nload_resistance = 3.5\ninductance = 0.0\ngear_ratio = 5.0\nrotor_inertia = 1e-6\n",
            models.display()
        )
        .unwrap();
    }
    write!(
        s,
        "[[excitation]]\nname = \"shaker\"\nat = {load}\namplitude = 2.0\ntime = {{ kind = \"harmonic\", frequency_hz = 18.0 }}\n\
         [integrator]\nmethod = \"newmark\"\ndt = 1e-4\nt_end = 0.15\n[output]\nevery = 10\n"
    )
    .unwrap();
    s
}

pub(crate) const BEAM: &str = "[beam]\n[[beam.segment]]\nlength = 1.0\nyoungs_modulus = 210e9\ndensity = 7850.0\nwidth = 0.040\nheight = 0.008\nelements = 24\n\
[[beam.support]]\nx = 0.0\nkind = \"pinned\"\n[[beam.support]]\nx = 1.0\nkind = \"pinned\"\n[beam.damping]\nratios = [{ mode = 1, ratio = 0.002 }, { mode = 2, ratio = 0.002 }]\n";

/// Writes the beam scenario, and the beam's matrices and tables beside it; returns the beam
/// scenario's path.
pub(crate) fn export(dir: &Path) -> std::path::PathBuf {
    let beam_path = dir.join("beam.toml");
    let text = scenario(
        BEAM,
        "x = 0.3333333333333333",
        "x = 0.6666666666666666",
        "{ x = 0.5 }",
    );
    std::fs::write(&beam_path, &text).unwrap();
    let sc = HybridScenario::from_str(&text, &beam_path).unwrap();
    let built = codegen_cli::setup::build(&sc).unwrap();
    let b = built.model.beam().unwrap();
    // M.mtx, K.mtx, C.mtx, nodes.csv (ids = node indices), dofs.csv (uy, rz).
    fem_structure::beam_structure_files(b)
        .write_to(dir)
        .unwrap();
    beam_path
}

/// `damper simulate P -o OUT --quiet`, which must succeed; returns `OUT`.
fn simulated(p: &Path, out: &Path) -> std::path::PathBuf {
    let (code, stdout, err) = damper(&[
        "simulate",
        p.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{stdout}\n{err}");
    out.to_path_buf()
}

/// A fresh directory under the system's temporary directory.
pub(crate) fn scratch(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("structure_cli_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub(crate) fn structure(extra: &str) -> String {
    format!(
        "[structure]\nkind = \"matrices\"\nmass = \"M.mtx\"\nstiffness = \"K.mtx\"\nnodes = \"nodes.csv\"\ndofs = \"dofs.csv\"\ndamping = \"C.mtx\"\n{extra}"
    )
}

/// Every cell of `time_history.csv` of two runs with the same columns: the largest
/// difference relative to each column's amplitude. The columns that are round-off by nature
/// are measured against what they are the round-off of: a constraint residual against 1 mm,
/// the energy balance's error and the structure's own loads' work (zero but for round-off
/// when every load is an excitation) against the stored energy.
fn worst(a: &Path, b: &Path) -> f64 {
    worst_of(a, "time_history.csv", b, "time_history.csv")
}

/// [`worst`] of the time history `fa` in `a` against `fb` in `b`.
fn worst_of(a: &Path, fa: &str, b: &Path, fb: &str) -> f64 {
    let read = |p: &Path, f: &str| {
        let mut r = csv::Reader::from_path(p.join(f)).unwrap();
        let h: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
        let rows: Vec<Vec<f64>> = r
            .records()
            // An empty cell (a figure undefined at that instant, e.g. a speed ratio at
            // rest) reads as NaN; both runs must leave the same cells empty.
            .map(|x| {
                x.unwrap()
                    .iter()
                    .map(|c| {
                        if c.is_empty() {
                            f64::NAN
                        } else {
                            c.parse().unwrap()
                        }
                    })
                    .collect()
            })
            .collect();
        normalised(h, rows)
    };
    let ((ha, ra), (hb, rb)) = (read(a, fa), read(b, fb));
    assert_eq!(ha, hb, "the same columns");
    assert_eq!(ra.len(), rb.len());
    let amplitude = |c: usize| ra.iter().fold(0.0f64, |m, r| m.max(r[c].abs()));
    let stored = ha.iter().position(|h| h == "stored [J]").unwrap();
    let mut worst = 0.0f64;
    for c in 0..ha.len() {
        let amp = if ha[c].contains("constraint_residual") {
            1e-3
        } else if ha[c].starts_with("balance_error") || ha[c].starts_with("beam_load_work") {
            amplitude(stored)
        } else {
            amplitude(c).max(1e-300)
        };
        for (x, y) in ra.iter().zip(&rb) {
            assert_eq!(
                x[c].is_nan(),
                y[c].is_nan(),
                "{}: empty in one run only",
                ha[c]
            );
            if !x[c].is_nan() {
                worst = worst.max((x[c] - y[c]).abs() / amp);
            }
        }
    }
    worst
}

/// A time history with a node attachment's columns as the beam's attachment writes them: a
/// node's `A.uy...` named `A.w...`, its `A.ux...` left out (they must be 0: the beam's
/// export has no `ux` equation).
fn normalised(h: Vec<String>, rows: Vec<Vec<f64>>) -> (Vec<String>, Vec<Vec<f64>>) {
    let keep: Vec<usize> = (0..h.len())
        .filter(|&c| {
            let ux = h[c].contains(".ux");
            if ux {
                assert!(rows.iter().all(|r| r[c] == 0.0), "{} is not 0", h[c]);
            }
            !ux
        })
        .collect();
    (
        keep.iter().map(|&c| h[c].replace(".uy", ".w")).collect(),
        rows.iter()
            .map(|r| keep.iter().map(|&c| r[c]).collect())
            .collect(),
    )
}

#[test]
fn the_beam_as_matrices_runs_as_the_beam() {
    let dir = scratch("runs");
    let d = dir.as_path();
    let beam = export(d);
    let full = d.join("full.toml");
    let reduced = d.join("reduced.toml");
    let host = |extra: &str| {
        scenario(
            &structure(extra),
            "node = 8",
            "node = 16",
            "{ node = 12, direction = [0.0, 1.0] }",
        )
    };
    std::fs::write(&full, host("")).unwrap();
    // Every fixed-interface mode (45; more are capped): 48 equations, 3 interface DOFs (the
    // three nodes' uy; the beam has no ux).
    std::fs::write(
        &reduced,
        host("reduction = { kind = \"craig_bampton\", modes = 47 }\n"),
    )
    .unwrap();
    let run = |p: &Path, out: &str| simulated(p, &d.join(out));
    let (a, b, c) = (
        run(&beam, "beam"),
        run(&full, "full"),
        run(&reduced, "reduced"),
    );
    let w = worst(&a, &b);
    assert!(w <= 1e-10, "imported vs beam: {w:e}");
    let w = worst(&a, &c);
    assert!(w <= 1e-10, "Craig–Bampton (every mode) vs beam: {w:e}");

    // The summary reports the host and the reduction's check: with every mode the reduced
    // frequencies are the full model's; with two, each lies above its full counterpart.
    let summary = |o: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(o.join("summary.json")).unwrap()).unwrap()
    };
    let s = summary(&c);
    assert_eq!(s["structure"]["kind"], "matrices, Craig–Bampton");
    // 25 nodes' uy and rz, less the two pinned ends' uy.
    assert_eq!(s["structure"]["equations"], 48);
    let check = &s["structure"]["reduction"];
    assert_eq!(check["interface"], 3);
    assert!(
        check["max_relative_error"].as_f64().unwrap() < 1e-9,
        "{check}"
    );
    assert_eq!(check["full_hz"].as_array().unwrap().len(), 10);
    assert_eq!(summary(&b)["structure"]["kind"], "matrices");
    let two = d.join("two.toml");
    std::fs::write(
        &two,
        host("reduction = { kind = \"craig_bampton\", modes = 2 }\n"),
    )
    .unwrap();
    let s = summary(&run(&two, "two"));
    let check = &s["structure"]["reduction"];
    let (full, reduced) = (
        check["full_hz"].as_array().unwrap(),
        check["reduced_hz"].as_array().unwrap(),
    );
    assert!(!full.is_empty() && full.len() == reduced.len(), "{check}");
    for (f, r) in full.iter().zip(reduced) {
        let (f, r) = (f.as_f64().unwrap(), r.as_f64().unwrap());
        assert!(r >= f * (1.0 - 1e-10), "reduced {r} Hz below full {f} Hz");
    }
    assert!(
        check["max_relative_error"].as_f64().unwrap() > 1e-9,
        "{check}"
    );
    // A harmonic above the cutoff is warned about.
    let fast = d.join("fast.toml");
    std::fs::write(
        &fast,
        host("reduction = { kind = \"craig_bampton\", modes = 1 }\n")
            .replace("frequency_hz = 18.0", "frequency_hz = 5000.0"),
    )
    .unwrap();
    let (code, _, err) = damper(&[
        "simulate",
        fast.to_str().unwrap(),
        "-o",
        d.join("fast").to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("above the reduction's cutoff"), "{err}");
    std::fs::remove_dir_all(d).unwrap();
}

/// `compare = ["bare_structure"]` on the beam's Matrix Market export is `bare_beam` on the
/// beam: the comparison run's time history (the structure alone under the same force, read
/// where the attachments were, `left_pin.uy`, `right_pin.uy` against the beam's `.w` at
/// `x = L/3, 2L/3`) within 1e-10 of each column's amplitude, as the runs with the dampers
/// ([`the_beam_as_matrices_runs_as_the_beam`]); the summary's entry under its own key and
/// label. `bare_beam` on a structure and `bare_structure` on a beam are refused in one line.
#[test]
fn bare_structure_on_the_beam_as_matrices_is_the_bare_beam() {
    let dir = scratch("bare");
    let d = dir.as_path();
    let beam = export(d);
    let text = std::fs::read_to_string(&beam).unwrap();
    let with =
        |t: &str, c: &str| t.replace("[output]\n", &format!("[output]\ncompare = [{c:?}]\n"));
    std::fs::write(&beam, with(&text, "bare_beam")).unwrap();
    let host = scenario(
        &structure(""),
        "node = 8",
        "node = 16",
        "{ node = 12, direction = [0.0, 1.0] }",
    );
    let full = d.join("full.toml");
    std::fs::write(&full, with(&host, "bare_structure")).unwrap();
    let run = |p: &Path, out: &str| simulated(p, &d.join(out));
    let (a, b) = (run(&beam, "beam"), run(&full, "full"));
    let w = worst_of(
        &a,
        "time_history_bare_beam.csv",
        &b,
        "time_history_bare_structure.csv",
    );
    assert!(w <= 1e-10, "bare structure vs bare beam: {w:e}");
    let header = std::fs::read_to_string(b.join("time_history_bare_structure.csv")).unwrap();
    let header = header.lines().next().unwrap();
    assert!(
        header
            .ends_with("left_pin.ux [m],left_pin.ux_dot [m/s],left_pin.uy [m],left_pin.uy_dot [m/s],right_pin.ux [m],right_pin.ux_dot [m/s],right_pin.uy [m],right_pin.uy_dot [m/s]"),
        "{header}"
    );
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("summary.json")).unwrap()).unwrap();
    let c = &s["comparisons"]["bare_structure"];
    assert_eq!(c["label"], "bare structure (no mechanism)");
    let peak = |s: &serde_json::Value| s["peak_amplitude"].as_f64().unwrap();
    let sa: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("summary.json")).unwrap()).unwrap();
    let pb = peak(&sa["comparisons"]["bare_beam"]);
    assert!((peak(c) - pb).abs() <= 1e-10 * pb, "{} vs {pb}", peak(c));

    // The wrong host's name, in one line naming the file and the key.
    std::fs::write(&full, with(&host, "bare_beam")).unwrap();
    std::fs::write(&beam, with(&text, "bare_structure")).unwrap();
    let out = d.join("out");
    for (p, needles) in [
        (
            &full,
            ["\"bare_beam\" is for a [beam]", "use \"bare_structure\""],
        ),
        (
            &beam,
            [
                "\"bare_structure\" is for a [structure]",
                "use \"bare_beam\"",
            ],
        ),
    ] {
        let e = assert_bad_input(
            &["simulate", p.to_str().unwrap(), "-o", out.to_str().unwrap()],
            &needles,
        );
        assert!(
            e.contains(p.to_str().unwrap()) && e.contains("[output] compare"),
            "{e}"
        );
    }
    std::fs::remove_dir_all(d).unwrap();
}

/// The frame (`scenarios/frame.toml`, 20 ms) with `compare = ["bare_structure"]` and
/// `[output] points = ["741:ux"]`: both runs write the damper's node's two components
/// (`pin.ux`, `pin.uy`, node 613) and the loaded node's `741:ux`; the comparison's energy
/// balance holds (1e-9 of the input work); the summaries' `points` peaks are the columns'
/// peaks (1e-12), the attachment's `peak_displacement` its `uy`; the bare structure sways
/// along x (peak `ux` above 100 times its `uy`). Against an independent computation: the same
/// runs on the unreduced model (1990 equations, sparse solves) give every `ux` column within
/// 1e-5 of its amplitude (measured 9.3e-7: Craig–Bampton with 30 modes).
#[test]
fn the_frame_runs_its_bare_structure() {
    let dir = scratch("frame_bare");
    let frame = root().join("scenarios/frame.toml");
    // The unreduced frame: the reduction line removed, paths made absolute.
    let full = dir.join("full.toml");
    let text = std::fs::read_to_string(&frame).unwrap();
    let base = root().join("scenarios");
    let text: String = text
        .lines()
        .filter(|l| !l.starts_with("reduction ="))
        .map(|l| {
            l.replace("\"frame/", &format!("\"{}/frame/", base.display()))
                .replace("\"../models/", &format!("\"{}/../models/", base.display()))
                + "\n"
        })
        .collect();
    std::fs::write(&full, text).unwrap();
    let run = |scenario: &Path, out: &str| {
        let o = dir.join(out);
        let (code, stdout, err) = damper(&[
            "simulate",
            scenario.to_str().unwrap(),
            "-o",
            o.to_str().unwrap(),
            "--set",
            "integrator.t_end=0.02",
            "--set",
            "output.compare=[\"bare_structure\"]",
            "--set",
            "output.points=[\"741:ux\"]",
            "--quiet",
        ]);
        assert_eq!(code, 0, "{stdout}\n{err}");
        o
    };
    let (o, of) = (run(&frame, "out"), run(&full, "full"));
    let columns = |o: &Path, f: &str| -> (Vec<String>, Vec<Vec<f64>>) {
        let mut r = csv::Reader::from_path(o.join(f)).unwrap();
        let h: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
        let rows = r
            .records()
            .map(|x| {
                x.unwrap()
                    .iter()
                    .map(|c| c.parse::<f64>().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect();
        (h, rows)
    };
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o.join("summary.json")).unwrap()).unwrap();
    let c = &s["comparisons"]["bare_structure"];
    assert_eq!(c["label"], "bare structure (no mechanism)");
    assert!(
        c["energy_balance_rel_error"].as_f64().unwrap() < 1e-9,
        "{c}"
    );
    let mut bare_peaks = vec![];
    for (f, block) in [
        ("time_history.csv", &s),
        ("time_history_bare_structure.csv", c),
    ] {
        let (h, rows) = columns(&o, f);
        let (hf, rows_f) = columns(&of, f);
        assert_eq!(h, hf, "{f}: the same columns reduced and unreduced");
        let col = |name: &str| {
            h.iter()
                .position(|c| c == name)
                .unwrap_or_else(|| panic!("{f}: no {name} in {h:?}"))
        };
        let peak = |k: usize| rows.iter().fold(0.0f64, |m, r| m.max(r[k].abs()));
        let mut peaks = vec![];
        for name in ["pin.ux", "pin.uy", "741:ux"] {
            let k = col(&format!("{name} [m]"));
            col(&format!("{name}_dot [m/s]"));
            let p = peak(k);
            let reported = block["points"]
                .as_array()
                .unwrap()
                .iter()
                .find(|e| e["name"] == name)
                .unwrap_or_else(|| panic!("{f}: no point {name}"))["peak_displacement"]
                .as_f64()
                .unwrap();
            assert!(
                (reported - p).abs() <= 1e-12 * p,
                "{f} {name}: {reported} vs {p}"
            );
            if name.ends_with("ux") {
                let err = rows
                    .iter()
                    .zip(&rows_f)
                    .fold(0.0f64, |m, (a, b)| m.max((a[k] - b[k]).abs()));
                assert!(err <= 1e-5 * p, "{f} {name}: reduced vs full {:e}", err / p);
            }
            peaks.push(p);
        }
        let a = &block["attachments"][0];
        assert_eq!(a["name"], "pin");
        let uy = a["peak_displacement"].as_f64().unwrap();
        assert!((uy - peaks[1]).abs() <= 1e-12 * uy, "{a} vs {}", peaks[1]);
        bare_peaks = peaks;
    }
    // The bare structure sways along x.
    assert!(
        bare_peaks[0] > 100.0 * bare_peaks[1] && bare_peaks[2] > 0.0,
        "{bare_peaks:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_structure_input_is_refused_in_one_line() {
    let dir = scratch("bad");
    let d = dir.as_path();
    export(d);
    let write = |name: &str, text: String| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let run = |p: &str, needles: &[&str]| {
        assert_bad_input(
            &["simulate", p, "-o", d.join("out").to_str().unwrap()],
            needles,
        );
    };
    let ok_at = "{ node = 12, direction = [0.0, 1.0] }";
    // An unknown node.
    let p = write(
        "unknown.toml",
        scenario(&structure(""), "node = 99", "node = 16", ok_at),
    );
    run(&p, &["attachment \"left_pin\"", "no node 99"]);
    // A beam abscissa on a structure.
    let p = write(
        "abscissa.toml",
        scenario(&structure(""), "x = 0.5", "node = 16", ok_at),
    );
    run(&p, &["attachment \"left_pin\"", "name a node"]);
    // Both hosts.
    let p = write(
        "both.toml",
        scenario(
            &format!("{BEAM}{}", structure("")),
            "x = 0.5",
            "x = 0.25",
            "{ x = 0.5 }",
        ),
    );
    run(&p, &["[structure]", "not both"]);
    // A missing matrix file names it.
    let p = write(
        "missing.toml",
        scenario(
            &structure("").replace("K.mtx", "nowhere.mtx"),
            "node = 8",
            "node = 16",
            ok_at,
        ),
    );
    run(&p, &["nowhere.mtx"]);
    // A force at a node without a direction.
    let p = write(
        "direction.toml",
        scenario(&structure(""), "node = 8", "node = 16", "{ node = 12 }"),
    );
    run(&p, &["excitation \"shaker\"", "direction"]);
    // A held node (node 0 is pinned: no uy).
    let p = write(
        "held.toml",
        scenario(&structure(""), "node = 0", "node = 16", ok_at),
    );
    run(&p, &["node 0", "support"]);
    // A support motion's direction: zero, not a number, along a beam's axis, on a force,
    // and two support motions along different directions.
    for (name, host, at, needles) in [
        (
            "zero",
            structure(""),
            "[0.0, 0.0]",
            &["direction must be two finite numbers", "[0, 0]"][..],
        ),
        (
            "nan",
            structure(""),
            "[nan, 1.0]",
            &["direction must be two finite numbers", "[nan, 1]"][..],
        ),
        (
            "axial",
            BEAM.to_string(),
            "[1.0, 0.0]",
            &["transverse y only", "needs a [structure]"][..],
        ),
    ] {
        let (left, right) = if host == BEAM {
            ("x = 0.25", "x = 0.75")
        } else {
            ("node = 8", "node = 16")
        };
        let at = format!("\"base\"\ndirection = {at}");
        let p = write(
            &format!("base_{name}.toml"),
            scenario(&host, left, right, &at),
        );
        run(
            &p,
            &[&["excitation \"shaker\"", "base_"][..], needles].concat(),
        );
    }
    let p = write(
        "base_force.toml",
        scenario(
            &structure(""),
            "node = 8",
            "node = 16",
            &format!("{ok_at}\ndirection = [1.0, 0.0]"),
        ),
    );
    run(&p, &["excitation \"shaker\"", "for a support motion"]);
    let second = "[[excitation]]\nname = \"second\"\nat = \"base\"\ndirection = [1.0, 0.0]\namplitude = 1.0\ntime = { kind = \"harmonic\", frequency_hz = 5.0 }\n";
    let p = write(
        "base_two.toml",
        scenario(&structure(""), "node = 8", "node = 16", "\"base\"") + second,
    );
    run(
        &p,
        &[
            "excitation \"second\"",
            "one direction",
            "\"shaker\"'s [0, 1]",
        ],
    );
    std::fs::remove_dir_all(d).unwrap();
}

/// A support motion along `[0, 1]` on the beam's Matrix Market export is the beam's own
/// support motion (`at = "base"`): the time history (every column within 1e-10 of its
/// amplitude, as [`the_beam_as_matrices_runs_as_the_beam`]) and the linear frequency
/// response at the mid-span (node 12's `uy`, the beam's `x = 0.5`; with and without the
/// generators, the generators' currents and powers: 5e-10 of each column's amplitude —
/// measured 1.3e-10 on the receptance and 2.4e-10 on the powers (its square), at the first
/// resonance, where the damping ratio 0.002 amplifies the two factorisations' round-off,
/// the beam's banded LDL^T and the sparse LU, some 250 times; 1e-12 away from it).
#[test]
fn a_support_motion_along_y_on_the_beam_as_matrices_is_the_beams() {
    let dir = scratch("base");
    let d = dir.as_path();
    export(d);
    let beam = d.join("beam_base.toml");
    let at = "\"base\"";
    let text = scenario(BEAM, "x = 0.3333333333333333", "x = 0.6666666666666666", at);
    std::fs::write(&beam, text).unwrap();
    let full = d.join("full_base.toml");
    let at = "\"base\"\ndirection = [0.0, 1.0]";
    std::fs::write(&full, scenario(&structure(""), "node = 8", "node = 16", at)).unwrap();
    let run = |args: &[&str]| {
        let (code, stdout, err) = damper(args);
        assert_eq!(code, 0, "{stdout}\n{err}");
    };
    let (a, b) = (d.join("beam"), d.join("full"));
    for (p, o) in [(&beam, &a), (&full, &b)] {
        run(&[
            "simulate",
            p.to_str().unwrap(),
            "-o",
            o.to_str().unwrap(),
            "--quiet",
        ]);
    }
    let w = worst(&a, &b);
    assert!(w <= 1e-10, "imported vs beam: {w:e}");

    let frf = |p: &Path, output: &str, o: &Path| -> Vec<Vec<f64>> {
        let (p, o) = (p.to_str().unwrap(), o.to_str().unwrap());
        run(&[
            "frf", p, "--output", output, "--from", "2", "--to", "80", "--points", "60", "--out", o,
        ]);
        let mut r = csv::Reader::from_path(Path::new(o).join("frf.csv")).unwrap();
        r.records()
            .map(|x| {
                x.unwrap()
                    .iter()
                    .map(|c| c.parse().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect()
    };
    let (fa, fb) = (
        frf(&beam, "0.5", &d.join("frf_beam")),
        frf(&full, "12:uy", &d.join("frf_full")),
    );
    assert_eq!(fa.len(), 60);
    assert_eq!(fa.len(), fb.len());
    for c in 0..fa[0].len() {
        let amp = fa.iter().fold(0.0f64, |m, r| m.max(r[c].abs()));
        for (x, y) in fa.iter().zip(&fb) {
            assert_eq!(x[c].is_nan(), y[c].is_nan(), "column {c}");
            if x[c].is_finite() {
                assert!(
                    (x[c] - y[c]).abs() <= 5e-10 * amp,
                    "column {c}: {} vs {}",
                    x[c],
                    y[c]
                );
            }
        }
    }
    std::fs::remove_dir_all(d).unwrap();
}

/// A one-node structure in `dir`: node 7 at `at`, mass `m` on each of its two equations,
/// springs `k[0]`, `k[1]` on them; equation 0 is the node's `first` translation (`ux` or
/// `uy`), equation 1 the other.
pub(crate) fn one_node(dir: &Path, at: [f64; 2], m: f64, k: [f64; 2], first: &str) {
    let second = if first == "ux" { "uy" } else { "ux" };
    let diag = |a: f64, b: f64| {
        format!("%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n1 1 {a:e}\n2 2 {b:e}\n")
    };
    std::fs::write(dir.join("M.mtx"), diag(m, m)).unwrap();
    std::fs::write(dir.join("K.mtx"), diag(k[0], k[1])).unwrap();
    std::fs::write(
        dir.join("nodes.csv"),
        format!("id,x,y\n7,{},{}\n", at[0], at[1]),
    )
    .unwrap();
    std::fs::write(
        dir.join("dofs.csv"),
        format!("eq,node,dof\n0,7,{first}\n1,7,{second}\n"),
    )
    .unwrap();
}

/// A double bar (`models/double_bar.toml`, bars 0.1 m) with its generator pinned at node 7
/// of a one-node structure, placed by `placement` (the inside of the braces after the
/// attachment), mounted at `angle_deg`; a force along `force` at the node.
pub(crate) fn placed(placement: &str, angle_deg: f64, force: [f64; 2]) -> String {
    let models = root().join("models/double_bar.toml");
    format!(
        "kind = \"hybrid\"\n[structure]\nkind = \"matrices\"\nmass = \"M.mtx\"\nstiffness = \"K.mtx\"\nnodes = \"nodes.csv\"\ndofs = \"dofs.csv\"\n\
         [[mechanism]]\nname = \"damper\"\nmodel = {:?}\nangle_deg = {angle_deg:?}\n\
         placement = {{ attachment = \"pin\", {placement} }}\nmax_condition = 1e4\n\
         [[attachment]]\nname = \"pin\"\nmechanism = \"damper\"\npoint = \"tip\"\nkind = \"pin\"\nnode = 7\n\
         [[force]]\nname = \"gen\"\nmechanism = \"damper\"\njoint = \"crank\"\nkind = \"generator\"\nkt = 0.0235\nke = 0.0235\n\
         armature_resistance = 1.5\nload_resistance = 3.5\ninductance = 0.0\ngear_ratio = 5.0\nrotor_inertia = 1e-6\n\
         [[excitation]]\nname = \"shaker\"\nat = {{ node = 7, direction = [{:?}, {:?}] }}\namplitude = 20.0\n\
         time = {{ kind = \"harmonic\", frequency_hz = 30.0 }}\n\
         [integrator]\nmethod = \"newmark\"\ndt = 1e-4\nt_end = 0.1\n",
        models.display(),
        force[0],
        force[1],
    )
}

/// `placement = { ..., pivot_direction = d, knee = "+" | "-" }` at a node: the assembled
/// double bar has its ground pivot at `2 L cos(a)` from the node along `d` (normalised),
/// whatever the mechanism's mounting angle (the direction is in the structure's frame), its
/// tip on the node, its crank at the half-angle `a` from the pivot -> node axis, and its knee
/// on the stated side of that axis (the sign of the cross product axis x (knee - pivot)).
#[test]
fn a_double_bar_is_placed_at_a_node_along_a_direction() {
    let dir = scratch("placed");
    let d = dir.as_path();
    let node = [0.5, 0.25];
    one_node(d, node, 2.0, [4e4, 1e5], "ux");
    let (l, a) = (0.1f64, 10f64.to_radians());
    let cases: [([f64; 2], &str, f64); 6] = [
        ([1.0, 0.0], "+", 0.0),
        ([1.0, 0.0], "-", 0.0),
        ([0.0, 1.0], "-", 0.0),
        ([-1.0, 0.0], "+", 0.0),
        ([0.0, 2.5], "+", 0.0),
        ([-3.0, -4.0], "-", 30.0),
    ];
    for (direction, knee, angle_deg) in cases {
        let path = d.join("placed.toml");
        let text = placed(
            &format!(
                "half_angle_deg = 10.0, pivot_direction = [{:?}, {:?}], knee = \"{knee}\"",
                direction[0], direction[1]
            ),
            angle_deg,
            [1.0, 0.0],
        );
        std::fs::write(&path, &text).unwrap();
        let sc = HybridScenario::from_str(&text, &path).unwrap();
        let built = codegen_cli::setup::build(&sc).unwrap();
        let m = &built.model.mechanisms[0];
        let n = direction[0].hypot(direction[1]);
        let pivot = m.mount.origin;
        let expected = [
            node[0] + 2.0 * l * a.cos() * direction[0] / n,
            node[1] + 2.0 * l * a.cos() * direction[1] / n,
        ];
        let case = format!("{direction:?} {knee} at {angle_deg} deg");
        for k in 0..2 {
            assert!(
                (pivot[k] - expected[k]).abs() <= 1e-15,
                "{case}: pivot {pivot:?}, expected {expected:?}"
            );
        }
        // The crank and the coupler from the assembled coordinates, in the structure frame.
        let q = &built.state.mechanisms[0].q;
        let knee_at = m.mount.to_beam([l * q[0].cos(), l * q[0].sin()]);
        let tip = m.mount.to_beam([
            l * q[0].cos() + l * (q[0] + q[1]).cos(),
            l * q[0].sin() + l * (q[0] + q[1]).sin(),
        ]);
        assert!(
            (tip[0] - node[0]).abs() <= 1e-12 && (tip[1] - node[1]).abs() <= 1e-12,
            "{case}: tip {tip:?} not on the node"
        );
        let axis = [node[0] - pivot[0], node[1] - pivot[1]];
        let crank = [knee_at[0] - pivot[0], knee_at[1] - pivot[1]];
        let cross = axis[0] * crank[1] - axis[1] * crank[0];
        let dot = axis[0] * crank[0] + axis[1] * crank[1];
        let side = if knee == "+" { 1.0 } else { -1.0 };
        assert!(cross * side > 0.0, "{case}: knee on the wrong side");
        let half = cross.abs().atan2(dot);
        assert!((half - a).abs() <= 1e-12, "{case}: half-angle {half}");
    }
    std::fs::remove_dir_all(d).unwrap();
}

/// The same physical system turned by 90 degrees: pivot direction `[0, -1]` -> `[1, 0]`, the
/// force `[1, 0.5]` -> `[-0.5, 1]`, the structure's equations `ux, uy` -> `uy, ux` (its
/// springs turned with it: the stiffness along x becomes the stiffness along y). The turned
/// run's structure coordinates are `(u, -v)` of the first's and its crank angle is the
/// first's plus 90 degrees (coupler angle equal), to 1e-9 of the amplitudes over 0.1 s with
/// the generator's damping. The mechanism's mount is not turned: only the placement is.
#[test]
fn a_placement_turned_with_the_structure_gives_the_turned_trajectory() {
    use hybrid_core::hybrid::{HybridState, Integrator};
    let run = |name: &str, first: &str, pivot: [f64; 2], force: [f64; 2]| -> Vec<HybridState> {
        let dir = scratch(name);
        one_node(&dir, [0.0, 0.0], 0.5, [4e4, 1e5], first);
        let path = dir.join("turned.toml");
        let text = placed(
            &format!(
                "half_angle_deg = 10.0, pivot_direction = [{:?}, {:?}], knee = \"-\"",
                pivot[0], pivot[1]
            ),
            0.0,
            force,
        );
        std::fs::write(&path, &text).unwrap();
        let sc = HybridScenario::from_str(&text, &path).unwrap();
        let built = codegen_cli::setup::build(&sc).unwrap();
        let mut state = built.state.clone();
        let mut integrator =
            Integrator::new(&built.model, sc.method, sc.integrator.dt, &state).unwrap();
        let mut out = vec![state.clone()];
        for k in 1..=1000 {
            integrator.step(&built.model, &mut state).unwrap();
            if k % 20 == 0 {
                out.push(state.clone());
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
        out
    };
    let a = run("turn_a", "ux", [0.0, -1.0], [1.0, 0.5]);
    let b = run("turn_b", "uy", [1.0, 0.0], [-0.5, 1.0]);
    let amp = |i: usize| a.iter().fold(0.0f64, |m, s| m.max(s.q[i].abs()));
    assert!(amp(0) > 1e-5 && amp(1) > 1e-6, "{} {}", amp(0), amp(1));
    let qamp = a.iter().fold(0.0f64, |m, s| {
        m.max(s.mechanisms[0].q[0].abs())
            .max(s.mechanisms[0].q[1].abs())
    });
    assert!(a.last().unwrap().account.dissipated[0] > 0.0);
    for (x, y) in a.iter().zip(&b) {
        assert!((x.q[0] - y.q[0]).abs() <= 1e-9 * amp(0), "t = {}", x.t);
        assert!((x.q[1] + y.q[1]).abs() <= 1e-9 * amp(1), "t = {}", x.t);
        let (p, r) = (&x.mechanisms[0].q, &y.mechanisms[0].q);
        let crank = r[0] - p[0] - std::f64::consts::FRAC_PI_2;
        let crank =
            (crank + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        assert!(crank.abs() <= 1e-9 * qamp, "t = {}: crank {crank}", x.t);
        assert!((p[1] - r[1]).abs() <= 1e-9 * qamp, "t = {}", x.t);
    }
}

/// A pivot direction that is zero or not a number, an unknown knee, a knee without a
/// direction: one line naming the file, the line and the key.
#[test]
fn a_bad_pivot_direction_is_refused_in_one_line() {
    let dir = scratch("bad_direction");
    let d = dir.as_path();
    one_node(d, [0.0, 0.0], 2.0, [4e4, 1e5], "ux");
    let cases = [
        ("pivot_direction = [0.0, 0.0]", "pivot_direction must be"),
        ("pivot_direction = [nan, 1.0]", "pivot_direction must be"),
        (
            "pivot_direction = [1.0, 0.0], knee = \"up\"",
            "knee must be",
        ),
        ("knee = \"+\"", "knee goes with pivot_direction"),
    ];
    for (k, (extra, needle)) in cases.iter().enumerate() {
        let path = d.join(format!("bad{k}.toml"));
        let text = placed(&format!("half_angle_deg = 10.0, {extra}"), 0.0, [1.0, 0.0]);
        std::fs::write(&path, text).unwrap();
        let file_line = format!("bad{k}.toml:12:");
        assert_bad_input(
            &[
                "simulate",
                path.to_str().unwrap(),
                "-o",
                d.join("out").to_str().unwrap(),
            ],
            &[&file_line, "mechanism \"damper\"", needle],
        );
    }
    std::fs::remove_dir_all(d).unwrap();
}

/// A roller at a node along `[0, 1]` is the beam's roller: the two-damper beam with rollers
/// at x = L/3, 2L/3 and the same beam as matrices with rollers at its nodes 8 and 16 along
/// `direction = [0.0, 1.0]` give the same time history (every column within 1e-10 of its
/// amplitude). A roller at a node without a direction, a direction on a pin, a zero
/// direction and a direction a support holds are refused in one line.
#[test]
fn a_roller_at_a_node_along_y_is_the_beams_roller() {
    let dir = scratch("roller");
    let d = dir.as_path();
    export(d);
    let roller = |text: String| text.replace("kind = \"pin\"", "kind = \"roller\"");
    let beam = d.join("beam_roller.toml");
    std::fs::write(
        &beam,
        roller(scenario(
            BEAM,
            "x = 0.3333333333333333",
            "x = 0.6666666666666666",
            "{ x = 0.5 }",
        )),
    )
    .unwrap();
    let nodes = d.join("nodes_roller.toml");
    let along = |n: u32, dir: &str| format!("node = {n}\ndirection = {dir}");
    let at_node = |left: &str, right: &str| {
        roller(scenario(
            &structure(""),
            left,
            right,
            "{ node = 12, direction = [0.0, 1.0] }",
        ))
    };
    std::fs::write(
        &nodes,
        at_node(&along(8, "[0.0, 1.0]"), &along(16, "[0.0, 1.0]")),
    )
    .unwrap();
    let run = |p: &Path, out: &str| simulated(p, &d.join(out));
    let w = worst(&run(&beam, "beam"), &run(&nodes, "nodes"));
    assert!(w <= 1e-10, "roller at a node vs the beam's roller: {w:e}");

    let bad = |name: &str, text: String, needles: &[&str]| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        assert_bad_input(
            &[
                "simulate",
                p.to_str().unwrap(),
                "-o",
                d.join("out").to_str().unwrap(),
            ],
            needles,
        );
    };
    bad(
        "no_direction.toml",
        at_node("node = 8", &along(16, "[0.0, 1.0]")),
        &["attachment \"left_pin\"", "needs the direction"],
    );
    bad(
        "pin_direction.toml",
        scenario(
            &structure(""),
            &along(8, "[0.0, 1.0]"),
            "node = 16",
            "{ node = 12, direction = [0.0, 1.0] }",
        ),
        &[
            "attachment \"left_pin\"",
            "direction is for a roller at a node",
        ],
    );
    bad(
        "zero_direction.toml",
        at_node(&along(8, "[0.0, 0.0]"), &along(16, "[0.0, 1.0]")),
        &[
            "attachment \"left_pin\"",
            "direction must be two finite numbers",
        ],
    );
    // The beam as matrices has no ux: a roller along x has nothing to follow.
    bad(
        "held_direction.toml",
        at_node(&along(8, "[1.0, 0.0]"), &along(16, "[0.0, 1.0]")),
        &["attachment \"left_pin\"", "node 8 cannot move along [1, 0]"],
    );
    std::fs::remove_dir_all(d).unwrap();
}

/// Bad `[output] points` entries, on a structure (the beam's Matrix Market export: nodes with
/// `uy` and `rz`, node 0 on a support) and on the beam: each is refused in one line naming
/// the file, the entry's line and the entry, with a non-zero exit and no output written. An
/// unknown node, a DOF outside the plane, a direction the node has no equation for, a node a
/// support holds, an abscissa on a structure (name a node as `NODE:DOF`), a word; an abscissa
/// off the beam, one a support locks, a node on the beam.
#[test]
fn bad_output_points_are_refused_in_one_line_naming_the_entry() {
    let dir = scratch("bad_points");
    let d = dir.as_path();
    export(d);
    let on_nodes = scenario(
        &structure(""),
        "node = 8",
        "node = 16",
        "{ node = 12, direction = [0.0, 1.0] }",
    );
    let on_beam = scenario(
        BEAM,
        "x = 0.3333333333333333",
        "x = 0.6666666666666666",
        "{ x = 0.5 }",
    );
    // (host, scenario, entry, what the message must say: the entry's name among it)
    let cases: [(&str, &str, &str, &[&str]); 10] = [
        (
            "nodes",
            &on_nodes,
            "99999:ux",
            &["99999:ux", "no node 99999"],
        ),
        ("nodes", &on_nodes, "8:rz", &["8:rz", "DOF ux or uy"]),
        (
            "nodes",
            &on_nodes,
            "8:ux",
            &["8:ux", "a support holds node 8 along it"],
        ),
        (
            "nodes",
            &on_nodes,
            "0:uy",
            &["0:uy", "node 0 has no ux or uy equation"],
        ),
        (
            "nodes",
            &on_nodes,
            "0.5",
            &["\"0.5\"", "name a node as NODE:DOF"],
        ),
        ("nodes", &on_nodes, "tip", &["\"tip\"", "NODE:DOF"]),
        (
            "beam",
            &on_beam,
            "1.5",
            &["must lie on the beam, 0 to 1 m (got 1.5)"],
        ),
        (
            "beam",
            &on_beam,
            "0",
            &["w(x=0)", "a support locks the beam there"],
        ),
        (
            "beam",
            &on_beam,
            "8:uy",
            &["\"8:uy\"", "the host is a [beam]", "not NODE:DOF"],
        ),
        (
            "beam",
            &on_beam,
            "left",
            &["\"left\"", "give a beam abscissa"],
        ),
    ];
    for (k, (host, text, entry, needles)) in cases.iter().enumerate() {
        let name = format!("points{k}.toml");
        // The entry on the file's last line.
        let text = format!("{text}points = [{entry:?}]\n");
        let line = text.lines().count();
        let p = d.join(&name);
        std::fs::write(&p, &text).unwrap();
        let out = d.join(format!("out{k}"));
        let file_line = format!("{name}:{line}:");
        let mut all = vec![file_line.as_str(), "[output] points"];
        all.extend_from_slice(needles);
        let err = assert_bad_input(
            &["simulate", p.to_str().unwrap(), "-o", out.to_str().unwrap()],
            &all,
        );
        assert!(
            !out.exists(),
            "{host} {entry}: output written despite {err}"
        );
    }
    std::fs::remove_dir_all(d).unwrap();
}
