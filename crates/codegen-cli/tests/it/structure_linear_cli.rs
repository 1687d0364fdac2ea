//! The linearised analyses on `[structure]` hosts (issue #30, item 5): the two-damper beam
//! written out as Matrix Market files linearises, and responds to white noise, as the beam
//! (1e-10); the bundled frame reduced by Craig–Bampton to 30 fixed-interface modes gives the
//! first coupled mode of its full 1,990-equation model within 1e-6; `NODE:DOF` outputs and
//! their bad forms.

use std::path::Path;

use serde_json::Value;

use crate::common::{assert_bad_input, damper, root};
use crate::structure_cli::{export, scratch, structure};

fn json(args: &[&str]) -> Value {
    let (code, out, err) = damper(args);
    assert_eq!(code, 0, "damper {args:?}: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"))
}

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!(
        (a - b).abs() <= tol * b.abs(),
        "{what}: {a} vs {b} ({:e})",
        (a - b).abs() / b.abs()
    );
}

/// `(f_n, zeta)` of every mode of `report[variant]`.
fn modes(report: &Value, variant: &str) -> Vec<(f64, f64)> {
    report[variant]
        .as_array()
        .unwrap_or_else(|| panic!("no {variant}"))
        .iter()
        .map(|m| {
            (
                m["natural_frequency_hz"].as_f64().unwrap(),
                m["damping_ratio"].as_f64().unwrap(),
            )
        })
        .collect()
}

const HARMONIC: &str = "amplitude = 2.0\ntime = { kind = \"harmonic\", frequency_hz = 18.0 }";
const NOISE: &str = "time = { kind = \"white_noise\", psd = 0.5, band = [1.0, 300.0] }";

#[test]
fn the_beam_as_matrices_linearises_as_the_beam() {
    let dir = scratch("linear");
    let d = dir.as_path();
    let beam = export(d);
    let text = std::fs::read_to_string(&beam).unwrap();
    let as_matrices = |extra: &str| on_the_nodes(&text, extra, "");
    let write = |name: &str, t: &str| write_in(d, name, t);
    let full = write("full.toml", &as_matrices(""));
    let beam = beam.display().to_string();

    let a = json(&["linearize", &beam, "--modes", "4", "--json"]);
    let b = json(&["linearize", &full, "--modes", "4", "--json"]);
    same_modes(&a, &b, "pins");
    assert!(b.get("bare_beam").is_none(), "the host is not a beam");

    // White noise at mid-span: every default output's RMS (the attachments' transverse
    // displacements and rates, the mechanisms' coordinates) and the generators' power.
    let noisy = |t: &str| t.replace(HARMONIC, NOISE);
    let beam_noise = write("beam_noise.toml", &noisy(&text));
    let full_noise = write("full_noise.toml", &noisy(&as_matrices("")));
    let ra = json(&["random", &beam_noise, "--json"]);
    let rb = json(&["random", &full_noise, "--json"]);
    let rms = |r: &Value| -> Vec<(String, f64)> {
        r["outputs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|o| {
                (
                    o["name"].as_str().unwrap().to_string(),
                    o["rms"].as_f64().unwrap(),
                )
            })
            .collect()
    };
    let (oa, ob) = (rms(&ra), rms(&rb));
    assert_eq!(oa.len(), ob.len());
    assert_eq!(ob[0].0, "8:uy", "a node's output is NODE:DOF");
    for ((na, xa), (nb, xb)) in oa.iter().zip(&ob) {
        close(*xb, *xa, 1e-10, &format!("RMS of {nb} ({na})"));
    }
}

/// The beam scenario `text` written by [`export`] with its `[beam]` replaced by the exported
/// matrices (`structure(extra)`): the attachments at nodes 8 and 16 (`attach` after each
/// `node = N` line), the load at node 12 along `y` (node ids are the beam's node indices).
fn on_the_nodes(text: &str, extra: &str, attach: &str) -> String {
    let host_start = text.find("[beam]").unwrap();
    let host_end = text.find("[[mechanism]]").unwrap();
    let mut t = text.to_string();
    t.replace_range(host_start..host_end, &structure(extra));
    t.replace("x = 0.3333333333333333", &format!("node = 8{attach}"))
        .replace("x = 0.6666666666666666", &format!("node = 16{attach}"))
        .replace(
            "at = { x = 0.5 }",
            "at = { node = 12, direction = [0.0, 1.0] }",
        )
}

/// Writes `text` to `dir/name`; its path.
fn write_in(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

/// The beam's `damper linearize` report `a` and the same structure's as matrices `b` have
/// the same modes with and without the generators and the same bare structure (1e-10).
fn same_modes(a: &Value, b: &Value, what: &str) {
    for (va, vb) in [
        ("modes", "modes"),
        ("generator_disconnected", "generator_disconnected"),
        ("bare_beam", "bare_structure"),
    ] {
        let (ma, mb) = (modes(a, va), modes(b, vb));
        assert!(!ma.is_empty(), "{what}: {va}");
        assert_eq!(ma.len(), mb.len(), "{what}: {vb}");
        for ((fa, za), (fb, zb)) in ma.iter().zip(&mb) {
            close(*fb, *fa, 1e-10, &format!("{what}: {vb} frequency"));
            close(*zb, *za, 1e-10, &format!("{what}: {vb} damping"));
        }
    }
}

/// The first row of a sweep's `sweep.csv`: the value of the column whose header starts with
/// a figure's name.
fn first_sweep_row(csv: &Path) -> impl Fn(&str) -> f64 + use<> {
    let mut r = csv::Reader::from_path(csv).unwrap();
    let h: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    let row: Vec<String> = r
        .records()
        .next()
        .unwrap()
        .unwrap()
        .iter()
        .map(str::to_string)
        .collect();
    let file = csv.display().to_string();
    move |figure: &str| -> f64 {
        let i = h
            .iter()
            .position(|c| c.starts_with(figure))
            .unwrap_or_else(|| panic!("{file}: no {figure} in {h:?}"));
        row[i]
            .parse()
            .unwrap_or_else(|_| panic!("{file}: {figure} = {:?}", row[i]))
    }
}

/// The bundled frame with its paths made absolute, its reduction line replaced by `reduction`.
fn frame(dir: &Path, name: &str, reduction: &str) -> String {
    let src = root().join("scenarios");
    let text = std::fs::read_to_string(src.join("frame.toml"))
        .unwrap()
        .replace("\"frame/", &format!("\"{}/frame/", src.display()))
        .replace("\"../models/", &format!("\"{}/../models/", src.display()))
        .replace(
            "reduction = { kind = \"craig_bampton\", modes = 30 }",
            reduction,
        );
    write_in(dir, name, &text)
}

#[test]
fn thirty_fixed_interface_modes_give_the_frames_first_coupled_mode() {
    let dir = scratch("frame_linear");
    let d = dir.as_path();
    let reduced = frame(
        d,
        "reduced.toml",
        "reduction = { kind = \"craig_bampton\", modes = 30 }",
    );
    let full = frame(d, "full.toml", "");
    let a = json(&["linearize", &full, "--modes", "2", "--json"]);
    let b = json(&["linearize", &reduced, "--modes", "2", "--json"]);
    assert_eq!(
        b["modes"][0]["structure_shape"].as_array().unwrap().len(),
        995
    );
    let (fa, za) = modes(&a, "modes")[0];
    let (fb, zb) = modes(&b, "modes")[0];
    close(fb, fa, 1e-6, "first coupled frequency");
    close(zb, za, 1e-6, "first coupled damping ratio");
    // The damper adds damping to the sway mode.
    let (_, bare) = modes(&a, "bare_structure")[0];
    assert!(za > 1.2 * bare, "zeta {za} vs bare {bare}");
    // The pin couples both components; the sway (x) is the amplified one.
    let amp: Vec<(String, f64)> = a["amplification"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| {
            (
                x["component"].as_str().unwrap().to_string(),
                x["joint_per_displacement"].as_f64().unwrap().abs(),
            )
        })
        .collect();
    assert_eq!(amp.len(), 2);
    assert!(amp[1].0 == "x" && amp[1].1 > 5.0 * amp[0].1, "{amp:?}");
    // The reduced model's report carries the check: the full model's first coupled mode, as
    // the full model's own run gives it (to the eigen-solvers' round-off: Arnoldi there, the
    // dense solver here), and the differences of the reduced one.
    assert!(
        a.get("structure")
            .is_some_and(|s| s.get("reduction").is_none())
    );
    let check = &b["structure"]["reduction"]["first_coupled"];
    assert_eq!(check["status"], "compared", "{check}");
    let field = |k: &str| check[k].as_f64().unwrap();
    close(field("full_hz"), fa, 1e-10, "checked full frequency");
    close(
        field("full_damping_ratio"),
        za,
        1e-8,
        "checked full damping ratio",
    );
    close(field("reduced_hz"), fb, 1e-14, "checked reduced frequency");
    close(
        field("frequency_error"),
        (fb - fa) / fa,
        1e-4,
        "frequency error",
    );
    assert!(field("frequency_error").abs() < 1e-6, "{check}");
    assert!(field("damping_error").abs() < 1e-6, "{check}");
    assert_eq!(b["structure"]["coordinates"], 34);
    assert_eq!(b["structure"]["equations"], 1990);
}

/// An excitation whose content reaches above the reduction's cutoff is warned about by
/// `damper linearize` and `damper simulate`: white noise whose band ends above the highest
/// fixed-interface mode kept (one mode), not a band below it.
#[test]
fn a_random_band_above_the_cutoff_is_warned_about() {
    let dir = scratch("cutoff_band");
    let d = dir.as_path();
    let path = frame(
        d,
        "one.toml",
        "reduction = { kind = \"craig_bampton\", modes = 1 }",
    );
    let lin = json(&["linearize", &path, "--modes", "1", "--json"]);
    let cutoff = lin["structure"]["reduction"]["cutoff_hz"].as_f64().unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let harmonic = "time = { kind = \"harmonic\", frequency_hz = 38.9 }";
    assert!(text.contains(harmonic));
    let noisy = |top: f64| {
        let p = d.join(format!("noise{top}.toml"));
        let noise = format!("time = {{ kind = \"white_noise\", psd = 0.5, band = [1.0, {top}] }}");
        std::fs::write(
            &p,
            text.replace(harmonic, &noise)
                .replace("amplitude = 5.0", ""),
        )
        .unwrap();
        let (code, _, err) = damper(&["linearize", p.to_str().unwrap(), "--modes", "1"]);
        assert_eq!(code, 0, "{err}");
        err
    };
    let err = noisy(2.0 * cutoff);
    let warned = |err: &str| {
        err.contains("warning: excitation shaker (band up to")
            && err.contains("above the reduction's cutoff")
    };
    assert!(warned(&err), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    // A simulation realises the noise before the run; its summary warns as well.
    let p = d.join(format!("noise{}.toml", 2.0 * cutoff));
    let out = d.join("sim");
    let (code, _, err) = damper(&[
        "simulate",
        p.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.t_end=0.01",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(warned(&err), "{err}");
    let err = noisy(0.5 * cutoff);
    assert!(!err.contains("warning"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn node_outputs_name_their_node_and_direction() {
    let dir = scratch("node_outputs");
    let frame = frame(
        dir.as_path(),
        "frame.toml",
        "reduction = { kind = \"craig_bampton\", modes = 10 }",
    );
    let out = dir.join("frf.csv").display().to_string();
    let frf = |o: &str| {
        [
            "frf",
            frame.as_str(),
            "--output",
            o,
            "--from",
            "30",
            "--to",
            "45",
            "--out",
            out.as_str(),
        ]
        .map(str::to_string)
    };
    let run = |o: &str| {
        let a = frf(o);
        let args: Vec<&str> = a.iter().map(String::as_str).collect();
        damper(&args)
    };
    let (code, _, err) = run("741:ux");
    assert_eq!(code, 0, "{err}");
    for (o, needles) in [
        ("741:rz", &["741:rz", "no DOF", "ux, uy"][..]),
        ("99999:ux", &["no node 99999"][..]),
        ("x:ux", &["NODE:DOF"][..]),
    ] {
        let a = frf(o);
        let args: Vec<&str> = a.iter().map(String::as_str).collect();
        assert_bad_input(&args, needles);
    }
    let damper_toml = root().join("scenarios/damper.toml").display().to_string();
    assert_bad_input(
        &[
            "frf",
            &damper_toml,
            "--output",
            "3:ux",
            "--from",
            "1",
            "--to",
            "2",
            "--out",
            &out,
        ],
        &["NODE:DOF needs a [structure]"],
    );
}

#[test]
fn a_sweep_on_the_frame_reads_node_outputs_and_the_pins_amplification() {
    let dir = scratch("frame_sweep");
    let d = dir.as_path();
    let path = frame(
        d,
        "noise.toml",
        "reduction = { kind = \"craig_bampton\", modes = 30 }",
    );
    let text = std::fs::read_to_string(&path).unwrap().replace(
        "amplitude = 5.0                 # N\ntime = { kind = \"harmonic\", frequency_hz = 38.9 }",
        "time = { kind = \"white_noise\", psd = 1.0, band = [5.0, 200.0] }",
    );
    assert!(text.contains("white_noise"));
    std::fs::write(&path, text).unwrap();
    let out = d.join("sweep").display().to_string();
    let (code, _, err) = damper(&[
        "sweep",
        &path,
        "--set",
        "force[0].load_resistance=3.5",
        "--map",
        "random.rms:613:ux",
        "--threads",
        "1",
        "--quiet",
        "-o",
        &out,
    ]);
    assert_eq!(code, 0, "{err}");
    let col = first_sweep_row(&d.join("sweep/sweep.csv"));
    // The pin's amplification is the x component's: 1 / (2 L sin 10 deg), L = 0.1 m.
    let g1 = 1.0 / (2.0 * 0.1 * 10f64.to_radians().sin());
    close(col("linear.amplification").abs(), g1, 1e-9, "amplification");
    // The node output of the sweep is `damper random --output 613:ux`'s.
    let rnd = json(&["random", &path, "--output", "613:ux", "--json"]);
    let rms = rnd["outputs"][0]["rms"].as_f64().unwrap();
    assert_eq!(rnd["outputs"][0]["name"], "613:ux");
    close(col("random.rms:613:ux"), rms, 1e-6, "RMS of 613:ux");
}

/// On a structure's node the double bar's reach is measured along the pivot -> node axis
/// (a node moves in the plane; the frame's pivot lies beside node 613 along x, the mount
/// turned by 90 degrees): at rest it is `2 L (1 - cos 10 deg)` (L = 0.1 m, the model's bars),
/// and the frequency response's admissible force is that reach over the receptance of the
/// node's `ux` (the axis), at every frequency.
#[test]
fn the_reach_at_a_node_is_along_the_pivot_axis() {
    let dir = scratch("node_reach");
    let frame = frame(
        dir.as_path(),
        "frame.toml",
        "reduction = { kind = \"craig_bampton\", modes = 10 }",
    );
    let lin = json(&["linearize", &frame, "--modes", "1", "--json"]);
    let reach = lin["equilibrium"]["mechanisms"][0]["reach"]
        .as_f64()
        .unwrap();
    close(
        reach,
        0.2 * (1.0 - 10f64.to_radians().cos()),
        1e-12,
        "reach at rest",
    );
    let out = dir.join("frf");
    let out = out.display().to_string();
    let args = [
        "frf", &frame, "--output", "613:ux", "--from", "30", "--to", "45", "--points", "16", "-o",
        &out,
    ];
    let (code, _, err) = damper(&args);
    assert_eq!(code, 0, "{err}");
    let (header, rows) = crate::amplification_cli::read_csv(&dir.join("frf").join("frf.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (h, f) = (col("|H| with generator [m/N]"), col("max_force [N]"));
    for r in &rows {
        close(r[f], reach / r[h], 1e-9, "max force = reach / |H(613:ux)|");
    }
}

/// A Craig–Bampton reduction above the work limits is refused from the structure's size line
/// alone, before its entries are read: a mass matrix that declares a million equations (and
/// holds none) asks for 8 n (4 p + r + k) = 2.2e9 bytes (p = 60, r = 4, k = 30), above the
/// 1 GiB limit; the same scenario at the frame's own size goes on to the loader.
#[test]
fn a_reduction_above_the_work_limits_is_refused_from_the_size_line() {
    let dir = scratch("reduction_budget");
    let d = dir.as_path();
    let scenario = frame(
        d,
        "big.toml",
        "reduction = { kind = \"craig_bampton\", modes = 30 }",
    );
    let fake = d.join("M.mtx");
    std::fs::write(
        &fake,
        "%%MatrixMarket matrix coordinate real symmetric\n% declared only\n1000000 1000000 1000000\n",
    )
    .unwrap();
    let text = std::fs::read_to_string(&scenario).unwrap();
    let mass = root().join("scenarios").join("frame/M.mtx");
    let text = text.replace(
        &format!("\"{}\"", mass.display()),
        &format!("\"{}\"", fake.display()),
    );
    assert!(text.contains(&fake.display().to_string()), "{text}");
    std::fs::write(&scenario, text).unwrap();
    let err = assert_bad_input(
        &["linearize", &scenario],
        &["memory of the Craig–Bampton reduction", "--allow-long"],
    );
    assert!(err.contains("2.0") && err.contains("GiB"), "{err}");
}

/// The reduction is built once per distinct structure and reused (issue #30): four sweep
/// points of a copy of the frame (its own paths, so no other test shares its cache
/// entries), evaluated at the same time on four threads with different load resistances,
/// read the files once and reduce them once; the reduction they share is bit for bit a
/// fresh `craig_bampton` of freshly read files (the uncached path), and each point's
/// figures are bit for bit those of the same point evaluated again alone.
#[test]
fn the_frames_reduction_is_built_once_for_every_sweep_point() {
    use codegen_cli::scenario::overrides::{Override, parse_value};
    use codegen_cli::setup::structures;
    use codegen_cli::sweep_point::{PointOptions, evaluate};
    use fem_structure::{DampingInput, ImportedStructure, MatrixFiles, craig_bampton};

    let dir = scratch("frame_cache");
    let d = dir.as_path();
    let copy = d.join("frame");
    std::fs::create_dir_all(&copy).unwrap();
    for f in ["M.mtx", "K.mtx", "nodes.csv", "dofs.csv", "elements.csv"] {
        std::fs::copy(root().join("scenarios/frame").join(f), copy.join(f)).unwrap();
    }
    let src = root().join("scenarios");
    let text = std::fs::read_to_string(src.join("frame.toml"))
        .unwrap()
        .replace("\"../models/", &format!("\"{}/../models/", src.display()));
    let path = d.join("frame.toml");
    std::fs::write(&path, &text).unwrap();
    let point = |r: f64| {
        let o = Override::new("force[0].load_resistance", parse_value(&r.to_string()), "").unwrap();
        evaluate(&path, &text, &[o], &PointOptions::default())
            .unwrap()
            .figures
            .iter()
            .map(|f| (f.name.clone(), f.value.map(f64::to_bits)))
            .collect::<Vec<_>>()
    };
    let values = [2.0, 3.5, 5.0, 8.0];
    let together: Vec<_> = std::thread::scope(|s| {
        let h: Vec<_> = values.iter().map(|&r| s.spawn(move || point(r))).collect();
        h.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let files = MatrixFiles {
        damping: DampingInput::Ratios([(1, 0.002), (2, 0.002)]),
        ..MatrixFiles::in_directory(&copy, DampingInput::None)
    };
    assert_eq!(structures::computations(&files), (1, 1));
    for (r, t) in values.iter().zip(&together) {
        assert_eq!(&point(*r), t, "load resistance {r}");
        assert!(t.iter().any(|(n, v)| n == "linear.f1" && v.is_some()));
    }
    assert_eq!(structures::computations(&files), (1, 1));

    // The cached reduction is the uncached one, bit for bit.
    let full = ImportedStructure::from_files(&files).unwrap();
    let source = codegen_cli::scenario::hybrid::StructureSource::Files(files.clone());
    let cached_full = structures::load(&source).unwrap();
    use fem_structure::tables::NodeDof::{Ux, Uy};
    let interface: Vec<usize> = [(613, Ux), (613, Uy), (741, Ux), (741, Uy)]
        .iter()
        .map(|k| full.dofs.equation[k])
        .collect();
    let mut interface = interface;
    interface.sort_unstable();
    let fresh = craig_bampton(
        &full.stiffness,
        &full.mass,
        full.damping.as_ref(),
        &interface,
        30,
    )
    .unwrap();
    let cached = structures::reduce(&source, &cached_full, &interface, 30).unwrap();
    assert_eq!(structures::computations(&files), (1, 1), "the sweep's key");
    assert_eq!(cached.interface, fresh.interface);
    for (a, b) in [
        (&cached.transform, &fresh.transform),
        (&cached.mass, &fresh.mass),
        (&cached.stiffness, &fresh.stiffness),
        (&cached.damping, &fresh.damping),
    ] {
        assert!(
            a.iter()
                .zip(b.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits())
        );
        assert_eq!(a.shape(), b.shape());
    }
}

/// `damper optimize` on a structure (the frame reduced to 10 fixed-interface modes): the
/// most damping under a 2 mm reach lies where the reach constraint is active,
/// `2 L (1 - cos a) = 2 mm` at the node (L = 0.1 m: a = acos(0.99), the frame has no static
/// load that would move the node along the pivot axis), at the lowest load resistance; the
/// adjoint gradient of the first mode's damping ratio on the reduced structure equals central
/// differences of `damper linearize` runs around the optimum.
#[test]
fn the_optimum_on_a_structure_is_on_its_reach_constraint_with_adjoint_gradients() {
    let dir = scratch("frame_optimize");
    let frame = frame(
        dir.as_path(),
        "frame.toml",
        "reduction = { kind = \"craig_bampton\", modes = 10 }",
    );
    let angle_path = "mechanism[0].placement.half_angle_deg";
    let resistance_path = "force[0].load_resistance";
    let j = json(&[
        "optimize",
        &frame,
        "--vary",
        &format!("{angle_path}=3:25"),
        "--vary",
        &format!("{resistance_path}=0.5:20"),
        "--maximize",
        "zeta1",
        "--constraint",
        "reach>=0.002",
        "--json",
    ]);
    let angle = j["optimum"][0][1].as_f64().unwrap();
    close(angle, 0.99f64.acos().to_degrees(), 1e-9, "optimum angle");
    assert_eq!(j["optimum"][1][1].as_f64(), Some(0.5));
    assert_eq!(j["at_bounds"][0][0], resistance_path);
    assert_eq!(j["at_bounds"][0][1], "lower");
    let c = &j["constraints"][0];
    assert_eq!(c["active"], true, "{c}");
    assert!(c["multiplier"].as_f64().unwrap() > 0.0, "{c}");
    assert_eq!(j["multipliers_nonnegative"], true);
    assert!(j["kkt_residual"].as_f64().unwrap() < 1e-6, "{j}");
    let g = &j["gradients"][0];
    assert_eq!(g["figure"], "linear.zeta1");
    assert_eq!(g["method"], "adjoint");
    // Central differences of linearize's first-mode damping ratio, independent of the
    // optimiser's semi-analytic adjoint (whose matrix derivatives are differences at 1e-4 of
    // each variable's range, one-sided of second order at a bound: the resistance sits on its
    // lower bound, so the adjoint carries an O(h^2) error, measured 1.9e-6 of the resistance
    // component and 1.5e-7 of the angle's, as on the beam). Steps 1e-4: the central
    // differences' own error is below 1e-8 (unchanged from 1e-3 to 1e-5).
    let zeta = |angle: f64, resistance: f64| {
        let lin = json(&[
            "linearize",
            &frame,
            "--modes",
            "1",
            "--json",
            "--set",
            &format!("{angle_path}={angle}"),
            "--set",
            &format!("{resistance_path}={resistance}"),
        ]);
        modes(&lin, "modes")[0].1
    };
    let h = 1e-4;
    let da = (zeta(angle + h, 0.5) - zeta(angle - h, 0.5)) / (2.0 * h);
    let dr = (zeta(angle, 0.5 + h) - zeta(angle, 0.5 - h)) / (2.0 * h);
    let adjoint: Vec<f64> = g["gradient"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let norm = da.hypot(dr);
    for (what, a, d) in [("angle", adjoint[0], da), ("resistance", adjoint[1], dr)] {
        assert!(
            (a - d).abs() <= 1e-5 * norm,
            "d zeta1 / d {what}: adjoint {a} vs differences {d}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run of the frame under white noise reports its random response under `damper random`'s
/// names and order: the pin's node `613:ux`, `613:uy` (not a beam abscissa), each RMS within
/// four standard errors of the linear prediction of `damper random` (damping raised to 5 % so
/// that the transient is short); in `random_psd.csv` each rate's prediction is its
/// displacement's times `(2 pi f)^2` (1e-9), the prediction paired with its own output.
#[test]
fn a_random_run_on_a_structure_names_its_nodes_as_damper_random() {
    let dir = scratch("frame_random_run");
    let d = dir.as_path();
    let path = frame(
        d,
        "noise.toml",
        "reduction = { kind = \"craig_bampton\", modes = 10 }",
    );
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("ratio = 0.002 }", "ratio = 0.05 }")
        .replace(
            "time = { kind = \"harmonic\", frequency_hz = 38.9 }",
            "time = { kind = \"white_noise\", psd = 0.5, band = [1.0, 200.0] }",
        )
        .replace("amplitude = 5.0", "");
    std::fs::write(&path, text).unwrap();
    let out = d.join("run");
    let (code, _, err) = damper(&[
        "simulate",
        &path,
        "-o",
        out.to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.t_end=2.0",
    ]);
    assert_eq!(code, 0, "{err}");
    let linear = json(&["random", &path, "--json"]);
    let predicted = |name: &str| {
        linear["outputs"]
            .as_array()
            .unwrap()
            .iter()
            .find(|o| o["name"] == name)
            .unwrap_or_else(|| panic!("no {name} in {linear}"))["rms"]
            .as_f64()
            .unwrap()
    };
    let summary: Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let block = &summary["random"]["outputs"];
    let names: Vec<&str> = block
        .as_array()
        .unwrap_or_else(|| panic!("{}", summary["random"]))
        .iter()
        .map(|o| o["name"].as_str().unwrap())
        .collect();
    assert_eq!(&names[..4], ["613:ux", "613:ux'", "613:uy", "613:uy'"]);
    for o in block.as_array().unwrap().iter().take(4) {
        let name = o["name"].as_str().unwrap();
        let (rms, se) = (
            o["rms"]["value"].as_f64().unwrap(),
            o["rms"]["standard_error"].as_f64().unwrap(),
        );
        let p = predicted(name);
        assert!(
            (rms - p).abs() <= 4.0 * se,
            "{name}: {rms} ± {se} vs linear {p}"
        );
    }
    let csv = std::fs::read_to_string(out.join("random_psd.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| {
        header
            .iter()
            .position(|h| *h == n)
            .unwrap_or_else(|| panic!("{n}: {header:?}"))
    };
    for dof in ["ux", "uy"] {
        let (x, v) = (
            col(&format!("613:{dof} prediction [m^2/Hz]")),
            col(&format!("613:{dof}' prediction [(m/s)^2/Hz]")),
        );
        for line in lines.clone() {
            let r: Vec<f64> = line.split(',').map(|c| c.parse().unwrap()).collect();
            let w2 = (2.0 * std::f64::consts::PI * r[0]).powi(2);
            assert!(
                (r[v] - w2 * r[x]).abs() <= 1e-9 * r[v].abs().max(1e-300),
                "{dof} at {} Hz",
                r[0]
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue #30: the reach figures of a double bar at a node under random load. The reach is
/// measured along the pivot -> node axis, so `random.reach_sigma:damper = a / sigma_x` and
/// `random.toggle_rate:damper = (sigma_v / sigma_x) exp(-a^2 / 2 sigma_x^2) / 2 pi` (Rice)
/// with `sigma_x`, `sigma_v` the RMS of the node's displacement along that axis and of its
/// rate. On the frame (30 fixed-interface modes, a white-noise force) with the pivot beside
/// node 613 along `x` (the bundled placement) the axis is `x`, and with
/// `pivot_direction = [0, -1]` (under the node, the force along `y` at the node) it is `y`:
/// `sigma_x`, `sigma_v` are then `damper random --output 613:ux` (`613:uy`) and its rate's,
/// computed by the Lyapunov equation's Schur form, while the sweep's figures come from the
/// complete modal decomposition (`random::modal_variances`); `a` is `damper linearize`'s
/// remaining reach. Both figures agree to 1e-10.
#[test]
fn the_reach_figures_at_a_node_are_along_its_pivot_axis() {
    let dir = scratch("node_reach_sigma");
    let d = dir.as_path();
    let base = frame(
        d,
        "base.toml",
        "reduction = { kind = \"craig_bampton\", modes = 30 }",
    );
    let text = std::fs::read_to_string(&base).unwrap();
    let harmonic =
        "amplitude = 5.0                 # N\ntime = { kind = \"harmonic\", frequency_hz = 38.9 }";
    assert!(text.contains(harmonic));
    let cases = [
        (
            "along_x",
            "613:ux",
            "",
            "at = { node = 741, direction = [1.0, 0.0] }",
            16.0,
        ),
        (
            "along_y",
            "613:uy",
            ", pivot_direction = [0.0, -1.0]",
            "at = { node = 613, direction = [0.0, 1.0] }",
            50.0,
        ),
    ];
    for (name, output, pivot, at, psd) in cases {
        let path = d.join(format!("{name}.toml"));
        let noise =
            format!("time = {{ kind = \"white_noise\", psd = {psd:?}, band = [5.0, 200.0] }}");
        let scenario = text
            .replace(harmonic, &noise)
            .replace("at = { node = 741, direction = [1.0, 0.0] }", at)
            .replace(
                "half_angle_deg = 10.0 }",
                &format!("half_angle_deg = 10.0{pivot} }}"),
            );
        std::fs::write(&path, scenario).unwrap();
        let path = path.display().to_string();
        let out = d.join(name).display().to_string();
        let (code, _, err) = damper(&[
            "sweep",
            &path,
            "--set",
            "force[0].load_resistance=3.5",
            "--map",
            "random.toggle_rate:damper",
            "--threads",
            "1",
            "--quiet",
            "-o",
            &out,
        ]);
        assert_eq!(code, 0, "{name}: {err}");
        let col = first_sweep_row(&d.join(name).join("sweep.csv"));
        let rnd = json(&["random", &path, "--output", output, "--json"]);
        assert_eq!(rnd["outputs"][0]["name"], output);
        let sx = rnd["outputs"][0]["rms"].as_f64().unwrap();
        let sv = rnd["outputs"][1]["rms"].as_f64().unwrap();
        let lin = json(&["linearize", &path, "--modes", "1", "--json"]);
        let a = lin["equilibrium"]["mechanisms"][0]["reach"]
            .as_f64()
            .unwrap();
        let reach_sigma = a / sx;
        // A reach of a few RMS: the toggle rate is a number, not an underflow.
        assert!(
            (2.0..5.0).contains(&reach_sigma),
            "{name}: a / sigma = {reach_sigma}"
        );
        let rate = sv / sx * (-0.5 * reach_sigma * reach_sigma).exp() / std::f64::consts::TAU;
        close(
            col("random.reach_sigma:damper"),
            reach_sigma,
            1e-10,
            &format!("{name}: reach / RMS({output})"),
        );
        close(
            col("random.toggle_rate:damper"),
            rate,
            1e-10,
            &format!("{name}: Rice's rate with RMS({output}')"),
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The linearised analyses take a roller's direction at a node. Along `[0, 1]` it is the
/// beam's roller: the two-damper beam with rollers at x = L/3, 2L/3 and its Matrix Market
/// export with rollers at nodes 8 and 16 along `[0.0, 1.0]` give the same modes with and
/// without the generators and the same bare structure (`damper linearize`, 1e-10). Along a
/// tilted direction `d` on a one-node structure with equal springs along `x` and `y`: the
/// node's motion across `d` does not reach the mechanism (the roller's point is free across
/// `d`), so one mode is the bare oscillator's, `f = sqrt(k / m) / 2 pi` with no damping
/// (1e-10), and the system turned as a whole (the roller along `d = (0.6, 0.8)`, the pivot
/// along `-d`, the mount turned by `atan2(0.8, 0.6)`) has the modes of the unturned one
/// (roller along `x`, pivot along `-x`), 1e-10.
#[test]
fn the_linearised_analyses_take_a_rollers_direction() {
    let dir = scratch("roller_linear");
    let d = dir.as_path();
    let beam = export(d);
    let text = std::fs::read_to_string(&beam)
        .unwrap()
        .replace("kind = \"pin\"", "kind = \"roller\"");
    let nodes = on_the_nodes(&text, "", "\ndirection = [0.0, 1.0]");
    let write = |name: &str, t: &str| write_in(d, name, t);
    // A roller leaves the double bar free to slide across it: a spring on each crank, at
    // its placed angle (the pinned scenario's equilibrium), holds it.
    let held = |t: &str, pinned: &str| -> String {
        let lin = json(&[
            "linearize",
            &write("pinned.toml", pinned),
            "--modes",
            "1",
            "--json",
        ]);
        let mut springs = String::new();
        for m in lin["equilibrium"]["mechanisms"].as_array().unwrap() {
            let (name, q) = (m["name"].as_str().unwrap(), m["q"][0][1].as_f64().unwrap());
            springs += &format!(
                "[[force]]\nname = \"spring_{name}\"\nmechanism = \"{name}\"\njoint = \"crank\"\nkind = \"spring\"\nk = 1.0\nq0 = {q:?}\n"
            );
        }
        t.replacen("[[excitation]]", &(springs + "[[excitation]]"), 1)
    };
    let pinned = text.replace("kind = \"roller\"", "kind = \"pin\"");
    let (text, nodes) = (held(&text, &pinned), held(&nodes, &pinned));
    assert!(nodes.contains("spring_right") && text.contains("spring_left"));
    let (beam_roller, node_roller) = (write("beam.toml", &text), write("nodes.toml", &nodes));
    let a = json(&["linearize", &beam_roller, "--modes", "4", "--json"]);
    let b = json(&["linearize", &node_roller, "--modes", "4", "--json"]);
    assert_eq!(modes(&a, "modes").len(), 4);
    same_modes(&a, &b, "roller");

    // A tilted roller on a one-node structure, equal springs along x and y.
    let (m, k) = (2.0, 4e4);
    crate::structure_cli::one_node(d, [0.5, 0.25], m, [k, k], "ux");
    let free = (k / m).sqrt() / std::f64::consts::TAU;
    let tilted = |name: &str, along: [f64; 2]| {
        let angle = along[1].atan2(along[0]).to_degrees();
        let t = crate::structure_cli::placed(
            &format!(
                "half_angle_deg = 10.0, pivot_direction = [{:?}, {:?}], knee = \"-\"",
                -along[0], -along[1]
            ),
            angle,
            along,
        )
        .replace(
            "kind = \"pin\"\nnode = 7",
            &format!(
                "kind = \"roller\"\nnode = 7\ndirection = [{:?}, {:?}]",
                along[0], along[1]
            ),
        );
        assert!(t.contains("roller"));
        let t = held(
            &t,
            &t.replace("kind = \"roller\"", "kind = \"pin\"").replace(
                &format!("\ndirection = [{:?}, {:?}]", along[0], along[1]),
                "",
            ),
        );
        let r = json(&["linearize", &write(name, &t), "--modes", "3", "--json"]);
        modes(&r, "modes")
    };
    let straight = tilted("along_x.toml", [1.0, 0.0]);
    let turned = tilted("along_d.toml", [0.6, 0.8]);
    assert_eq!(straight.len(), 3);
    let across = turned
        .iter()
        .find(|(f, _)| (f - free).abs() <= 1e-6 * free)
        .unwrap_or_else(|| panic!("no mode at {free} Hz across d: {turned:?}"));
    close(across.0, free, 1e-10, "the mode across d");
    assert!(across.1.abs() <= 1e-10, "undamped across d: {}", across.1);
    // The mechanism is in the other modes: one of them is damped by the generator.
    assert!(turned.iter().any(|(_, z)| *z > 1e-3), "{turned:?}");
    for ((fs, zs), (ft, zt)) in straight.iter().zip(&turned) {
        close(*ft, *fs, 1e-10, "turned frequency");
        // (The mode across the roller is undamped: its ratio is compared to 1e-10 absolute.)
        assert!(
            (zt - zs).abs() <= 1e-10 * zs.abs().max(1.0),
            "turned damping {zt} vs {zs}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
