//! `damper random` and random excitation (issue #20): the single-degree-of-freedom closed
//! forms of Crandall & Mark (1963), the Lyapunov, modal and PSD-integration methods against
//! each other, the seeded time-domain realisation against the linear values within their
//! batch-means standard errors, and bad input.

use crate::common;

use common::{assert_bad_input, damper, root};

fn json(args: &[&str]) -> serde_json::Value {
    let (code, out, err) = damper(args);
    assert_eq!(code, 0, "{args:?}: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{args:?}: {e}: {out}"))
}

/// A scenario file `name` in a fresh temporary directory, with the text's
/// `../models/` paths made absolute.
fn scenario_file(name: &str, text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("random_cli_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{name}.toml"));
    let models = root().join("models").display().to_string();
    std::fs::write(&p, text.replace("../models", &models)).unwrap();
    p.display().to_string()
}

/// The absorber of `scenarios/pendulum_absorber.toml` with its arm across the beam
/// (theta = 90 deg, the spring's rest angle): a small rotation moves the arm's mass along the
/// beam's axis, which the roller carriage does not follow, so the arm is a single degree of
/// freedom `J theta'' + c theta' + k theta = tau` decoupled from the beam: `J = l^2 (m_a/3 +
/// m_t) + n^2 J_r`, `c = n^2 k_t k_e / (R_a + R_L)` (the generator without inductance). The
/// torque `tau` on the arm's joint is white noise of one-sided PSD `G` (band [0.05, 400] Hz).
fn sdof_text(t_end: f64) -> String {
    let text = std::fs::read_to_string(root().join("scenarios/pendulum_absorber.toml")).unwrap();
    let i = text.find("# Released from rest").unwrap();
    let j = text.find("[integrator]").unwrap();
    let text = format!(
        "{}[[excitation]]\nname = \"torque\"\nat = {{ mechanism = \"absorber\", joint = \"arm\" }}\ntime = {{ kind = \"white_noise\", psd = 1e-6, band = [0.05, 400.0], seed = 3 }}\n\n[integrator]\ndt = 1e-3\nt_end = {t_end}\n[output]\nevery = 10\n",
        &text[..i]
    );
    let _ = j;
    text.replace(
        "initial = { s = 0.0, theta = 0.0 }",
        "initial = { s = 0.0, theta = 1.5707963267948966 }",
    )
    .replace("q0 = 0.0 ", "q0 = 1.5707963267948966 ")
}

const G: f64 = 1e-6;
const K: f64 = 0.5879;
const N: f64 = 5.0;
const KT: f64 = 0.0235;
const R: f64 = 5.0;
const RL: f64 = 3.5;

fn sdof_constants() -> (f64, f64) {
    let c = N * N * KT * KT / R;
    let j = 0.1f64.powi(2) * (0.01 / 3.0 + 0.03) + N * N * 1e-6;
    (c, j)
}

/// Crandall & Mark (1963), "Random vibration in mechanical systems", eqs. (2.43)-(2.48): for
/// `m x'' + c x' + k x = f`, `f` white of two-sided PSD `S0` per rad/s, `sigma_x^2 = pi S0 /
/// (k c)`, `sigma_v^2 = pi S0 / (m c)` and the mean input power, all dissipated in `c`,
/// `pi S0 / m`, independent of `c` and `k`. With the one-sided `G = 4 pi S0` per Hz:
/// `sigma_x^2 = G / (4 k c)`, `P = G / (4 m)`.
#[test]
fn single_degree_of_freedom_closed_forms() {
    let p = scenario_file("sdof", &sdof_text(10.0));
    let (c, j) = sdof_constants();
    let sigma_theta = (G / (4.0 * K * c)).sqrt();
    let sigma_rate = (G / (4.0 * j * c)).sqrt();
    let power = G / (4.0 * j);
    for method in ["dense", "modal", "auto"] {
        let r = json(&[
            "random",
            &p,
            "--output",
            "absorber/theta",
            "--method",
            method,
            "--json",
        ]);
        let rel = |a: f64, b: f64| (a / b - 1.0).abs();
        let o = &r["outputs"];
        assert_eq!(o[0]["name"], "absorber/theta");
        assert_eq!(o[1]["unit"], "rad/s");
        let g = &r["generators"][0];
        let checks = [
            ("theta", o[0]["rms"].as_f64().unwrap(), sigma_theta),
            ("theta'", o[1]["rms"].as_f64().unwrap(), sigma_rate),
            (
                "rotor speed",
                g["rms_rotor_speed"].as_f64().unwrap(),
                N * sigma_rate,
            ),
            (
                "current",
                g["rms_current"].as_f64().unwrap(),
                KT * N * sigma_rate / R,
            ),
            ("power", g["mean_power_dissipated"].as_f64().unwrap(), power),
            (
                "load power",
                g["mean_power_load"].as_f64().unwrap(),
                power * RL / R,
            ),
        ];
        for (what, got, want) in checks {
            // Exact up to the rounding of the Lyapunov solution (the modal basis spans the
            // arm's coordinate exactly: it is decoupled).
            assert!(rel(got, want) < 1e-9, "{method}: {what}: {got} vs {want}");
        }
    }
}

/// The seeded time-domain realisation of the same oscillator: RMS and mean power over the
/// stationary part agree with the closed forms within 4 batch-means standard errors (the
/// band [0.05, 400] Hz holds all but 1e-4 of the white-noise variance of this 6.4 Hz, 9.5 %
/// damped oscillator: below the statistical error), and the realisation's mean square over
/// its period is `G (f2 - f1)`.
#[test]
fn time_domain_realisation_agrees_with_the_closed_forms() {
    let p = scenario_file("sdof_run", &sdof_text(300.0));
    let out = std::env::temp_dir().join(format!("random_cli_{}_sdof_out", std::process::id()));
    let out = out.display().to_string();
    let (code, _, err) = damper(&["simulate", &p, "-o", &out, "--quiet"]);
    assert_eq!(code, 0, "{err}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{out}/summary.json")).unwrap())
            .unwrap();
    let r = &s["random"];
    let real = &r["realisations"][0];
    assert_eq!(real["seed"], 3);
    let ms = real["mean_square"].as_f64().unwrap();
    assert!((ms / (G * (400.0 - 0.05)) - 1.0).abs() < 1e-10, "{ms}");
    // The stationary part starts after 5 time constants of the slowest mode, the beam's
    // first (Rayleigh damping 0.2 %: 0.077 1/s), 65 s, later than the first tenth (30 s).
    let sigma = r["slowest_decay_rate"].as_f64().unwrap();
    assert!((sigma - 0.0766).abs() < 1e-3, "{sigma}");
    assert!((r["from"].as_f64().unwrap() - 5.0 / sigma).abs() < 1e-9);
    let (c, j) = sdof_constants();
    let within = |what: &str, got: f64, se: f64, want: f64| {
        assert!(se > 0.0 && se < 0.1 * want, "{what}: standard error {se}");
        assert!(
            (got - want).abs() < 4.0 * se,
            "{what}: {got} +- {se} vs {want}"
        );
    };
    let outputs = r["outputs"].as_array().unwrap();
    let theta = outputs
        .iter()
        .find(|o| o["name"] == "absorber/theta")
        .unwrap();
    within(
        "theta",
        theta["rms"]["value"].as_f64().unwrap(),
        theta["rms"]["standard_error"].as_f64().unwrap(),
        (G / (4.0 * K * c)).sqrt(),
    );
    let g = &r["generators"][0]["mean_power_dissipated"];
    within(
        "power",
        g["value"].as_f64().unwrap(),
        g["standard_error"].as_f64().unwrap(),
        G / (4.0 * j),
    );
    // The same seed gives the same run.
    let out2 = format!("{out}_again");
    let (code, _, err) = damper(&["simulate", &p, "-o", &out2, "--quiet"]);
    assert_eq!(code, 0, "{err}");
    let s2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{out2}/summary.json")).unwrap())
            .unwrap();
    assert_eq!(s2["random"], s["random"]);
}

/// On the bundled scenario the three methods agree: dense Lyapunov against the PSD
/// integration (independent: the pencil's harmonic responses, the white noise over
/// [0, inf)) to 1e-8 of every variance, the modal basis of every mode to 1e-8, and the default
/// modal basis (20 modes) within its reported truncation estimate.
#[test]
fn lyapunov_quadrature_and_modal_agree_on_the_bundled_scenarios() {
    for p in [
        "scenarios/random_damper.toml",
        "scenarios/random_base_damper.toml",
    ] {
        methods_agree(p);
    }
}

fn methods_agree(p: &str) {
    let run = |m: &[&str]| {
        let mut args = vec!["random", p, "--json"];
        args.extend_from_slice(m);
        json(&args)
    };
    let dense = run(&["--method", "dense"]);
    let quad = run(&["--method", "quadrature"]);
    let full = run(&["--method", "modal", "--modes", "100"]);
    let modal = run(&["--method", "modal"]);
    assert_eq!(dense["method"], "lyapunov dense");
    assert_eq!(quad["method"], "quadrature");
    let variances = |r: &serde_json::Value| -> Vec<f64> {
        let mut v: Vec<f64> = r["outputs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|o| o["rms"].as_f64().unwrap().powi(2))
            .collect();
        for g in r["generators"].as_array().unwrap() {
            v.push(g["rms_current"].as_f64().unwrap().powi(2));
            v.push(g["mean_power_load"].as_f64().unwrap());
        }
        v
    };
    let d = variances(&dense);
    assert_eq!(d.len(), 8, "w, w', q1, q1', q2, q2', current, load power");
    let truncation = modal["truncation"].as_f64().unwrap();
    assert!(truncation < 1e-3, "{truncation}");
    for (label, other, tol) in [
        ("quadrature", &quad, 1e-8),
        ("complete modal", &full, 1e-8),
        ("modal", &modal, truncation),
    ] {
        for (k, (a, b)) in d.iter().zip(variances(other)).enumerate() {
            assert!(
                (a - b).abs() <= tol * a.abs(),
                "{label}: value {k}: {a} vs {b} ({:.2e})",
                (a - b).abs() / a
            );
        }
    }
    assert!(dense["lyapunov_residual"].as_f64().unwrap() < 1e-12);
    assert!(quad["quadrature_error"].as_f64().unwrap() < 1e-8);
    // The band [0.5, 500] Hz holds all but 0.54 % (tip force) and 0.42 % (supports) of the
    // white-noise variance.
    let oob = dense["out_of_band"].as_f64().unwrap();
    assert!(oob > 0.0 && oob < 0.01, "{p}: {oob}");
}

/// The bundled damper on randomly shaken supports: the seeded time-domain run (58.5 s of
/// stationary response, the supports' inertial loads on every mass) against `damper
/// random` (the input vector `-(M_R r)` in the Lyapunov equation) within 4 batch-means
/// standard errors, for the tip's RMS, the generator's RMS current and its mean power.
#[test]
fn base_white_noise_time_domain_agrees_with_the_linear_response() {
    let p = "scenarios/random_base_damper.toml";
    let linear = json(&["random", p, "--json"]);
    let out = std::env::temp_dir().join(format!("random_cli_{}_base_out", std::process::id()));
    let (code, stdout, err) = damper(&["simulate", p, "-o", out.to_str().unwrap(), "--quiet"]);
    assert_eq!(code, 0, "{stdout} {err}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let r = &summary["random"];
    // The RMS against time: the tip's windows, its stationary level with its standard
    // error and where the stationary part starts, every label inside the view.
    let svg = crate::common::svg::checked(&out.join("random_rms.svg"), &["RMS [m]", "t [s]"]).text;
    for needle in [
        "w(x=1): RMS over windows of",
        "w(x=1): stationary RMS",
        "start of the stationary part,",
        "RMS [m]",
    ] {
        assert!(svg.contains(needle), "random_rms.svg lacks {needle:?}");
    }
    // One shape for outputs and powers alike: `{value, standard_error}`.
    let pair = |v: &serde_json::Value| {
        [
            v["value"].as_f64().unwrap(),
            v["standard_error"].as_f64().unwrap(),
        ]
    };
    let tip = r["outputs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["name"] == "w(x=1)")
        .unwrap();
    let g = &r["generators"][0];
    let lg = &linear["generators"][0];
    let checks = [
        (
            "tip RMS",
            pair(&tip["rms"]),
            linear["outputs"][0]["rms"].as_f64().unwrap(),
        ),
        (
            "RMS current",
            pair(&g["rms_current"]),
            lg["rms_current"].as_f64().unwrap(),
        ),
        (
            "mean power",
            pair(&g["mean_power_dissipated"]),
            lg["mean_power_dissipated"].as_f64().unwrap(),
        ),
    ];
    // Printed on stdout too, each with its standard error.
    for line in [
        "RMS w(x=1) = ",
        "RMS current ",
        "mean power dissipated ",
        "in the load ",
    ] {
        assert!(
            stdout.contains(line) && stdout.contains(" ± "),
            "{line}: {stdout}"
        );
    }
    let printed = format!(
        "RMS w(x=1) = {:.4e} ± {:.1e} m",
        tip["rms"]["value"].as_f64().unwrap(),
        tip["rms"]["standard_error"].as_f64().unwrap()
    );
    assert!(stdout.contains(&printed), "{printed}: {stdout}");
    for (what, [got, se], want) in checks {
        println!("{what}: time domain {got:.4e} +- {se:.2e}, linear {want:.4e}");
        assert!(
            se > 0.0 && (got - want).abs() < 4.0 * se,
            "{what}: {got} +- {se} vs {want}"
        );
    }
    std::fs::remove_dir_all(&out).unwrap();
}

/// A PSD table (`file =` as CSV) equal to a white noise on its range gives the white noise's
/// band-limited response: the table's quadrature against the dense Lyapunov value less the
/// out-of-band share, which bounds their difference.
#[test]
fn psd_table_file_matches_the_band_limited_white_noise() {
    let text = std::fs::read_to_string(root().join("scenarios/random_damper.toml")).unwrap();
    let table = text.replace(
        "time = { kind = \"white_noise\", psd = 1e-4, band = [0.5, 500.0], seed = 1 }",
        "time = { kind = \"psd\", file = \"wind.csv\" }",
    );
    assert_ne!(table, text);
    let p = scenario_file("table", &table);
    let dir = std::path::Path::new(&p).parent().unwrap();
    std::fs::write(dir.join("wind.csv"), "f,G\n0.5,1e-4\n500,1e-4\n").unwrap();
    let t = json(&["random", &p, "--json"]);
    let w = json(&["random", "scenarios/random_damper.toml", "--json"]);
    // A PSD table alone: `auto` integrates it on the pencil (no Lyapunov equation applies).
    assert_eq!(t["method"], "quadrature");
    let oob = w["out_of_band"].as_f64().unwrap();
    for (a, b) in t["outputs"]
        .as_array()
        .unwrap()
        .iter()
        .zip(w["outputs"].as_array().unwrap())
    {
        let (a, b) = (
            a["rms"].as_f64().unwrap().powi(2),
            b["rms"].as_f64().unwrap().powi(2),
        );
        assert!(
            a <= b * (1.0 + 1e-9) && a >= b * (1.0 - oob - 1e-6),
            "{a} vs {b}"
        );
    }
}

#[test]
fn bad_random_input_is_one_line() {
    let text = std::fs::read_to_string(root().join("scenarios/random_damper.toml")).unwrap();
    let with_amplitude = text.replace(
        "at = { x = 1.0 }                # a transverse force at the beam tip\ntime",
        "at = { x = 1.0 }\namplitude = 0.5\ntime",
    );
    assert_ne!(with_amplitude, text);
    let p = scenario_file("amp", &with_amplitude);
    assert_bad_input(
        &["random", &p],
        &["amp.toml:", "excitation \"wind\"", "remove `amplitude`"],
    );
    let harmonic = std::fs::read_to_string(root().join("scenarios/forced_damper.toml"))
        .unwrap()
        .replace("amplitude = 0.05                # N\n", "");
    let p = scenario_file("noamp", &harmonic);
    assert_bad_input(
        &["simulate", &p],
        &["noamp.toml:", "missing field `amplitude`"],
    );
    assert_bad_input(
        &["random", "scenarios/forced_damper.toml"],
        &["no random excitation"],
    );
    let nyquist = text.replace("dt = 1e-4 ", "dt = 2e-3 ");
    let p = scenario_file("nyquist", &nyquist);
    assert_bad_input(&["simulate", &p], &["nyquist.toml:", "Nyquist"]);
    let band = text.replace("band = [0.5, 500.0]", "band = [500.0, 0.5]");
    let p = scenario_file("band", &band);
    assert_bad_input(&["random", &p], &["band.toml:", "upper frequency"]);
    assert_bad_input(
        &["random", "scenarios/random_damper.toml", "--method", "fast"],
        &["--method \"fast\""],
    );
}

/// The classical closed form of base excitation (Crandall & Mark 1963, the mean power a
/// white-noise input puts into a linear system: `P = W b^T M^-1 b / 2` for a generalised
/// force `b w(t)` of intensity `W = G / 2`; for the supports' acceleration `b = -M r`, so
/// `P = G r^T M r / 4`, the mass moving with the supports times `G / 4`, `pi S0 m` in the
/// two-sided form), independent of the damping and the stiffness: the bundled damper on
/// white-noise supports (the generator without inductance is part of `C_R`), its total
/// mean dissipation `E[v^T C_R v]` from the Lyapunov covariance of the whole first-order
/// form, at three load resistances, against `G b^T M_R^-1 b / 4` with `b` the linear input
/// of the supports (`-(M_R r)`, checked in hybrid-core's base tests).
#[test]
fn base_white_noise_input_power_is_the_moving_mass_closed_form() {
    use hybrid_core::hybrid::{ExcitationTarget, Matrix, StateSpace};
    let g = 5e-5; // scenarios/random_base_damper.toml, (m/s^2)^2/Hz
    let mut powers = vec![];
    for r_load in ["1.0", "3.5", "20.0"] {
        let text = std::fs::read_to_string(root().join("scenarios/random_base_damper.toml"))
            .unwrap()
            .replacen(
                "load_resistance = 3.5",
                &format!("load_resistance = {r_load}"),
                1,
            );
        let p = scenario_file(&format!("base_power_{r_load}"), &text);
        let sc = codegen_cli::scenario::load(std::path::Path::new(&p)).unwrap();
        let lz = codegen_cli::setup::tangents_for(&sc).unwrap();
        let lin = lz.linearize(&lz.model).unwrap();
        assert!(lin.electrical.is_empty(), "a generator without inductance");
        let b = lin.force_vector(&ExcitationTarget::BASE_Y);
        let m = lin.dense(Matrix::Mass);
        let c = lin.dense(Matrix::Damping);
        let bv = nalgebra::DVector::from_column_slice(&b);
        let closed = g / 4.0 * bv.dot(&m.clone().lu().solve(&bv).unwrap());
        let ss = StateSpace::new(&lin, &[b], None).unwrap();
        let (cov, residual) = ss.covariance(&[g / 2.0]).unwrap();
        let n = m.nrows();
        let vv = cov.view((n, n), (n, n));
        let dissipated: f64 = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| c[(i, j)] * vv[(j, i)])
            .sum();
        let rel = dissipated / closed - 1.0;
        println!(
            "R_L = {r_load} ohm: E[v^T C v] = {dissipated:.9e} W, G b^T M^-1 b / 4 = {closed:.9e} W ({rel:.1e}), Lyapunov residual {residual:.1e}"
        );
        // The whole first-order form carries the stiff beam's omega_max^2 / omega_1^2 in
        // its rounding (the random helper measured 6e-7 against the modal solution).
        assert!(rel.abs() < 1e-5, "{rel}");
        powers.push(dissipated);
    }
    // Independent of the damping: the generator's share changes, the total does not.
    assert!((powers[0] / powers[2] - 1.0).abs() < 2e-5, "{powers:?}");
}

/// The stationary part starts after 5 time constants of the slowest linearised mode: on the
/// bundled damper (slowest decay rate 1.4231 1/s, the second mode's, below the first's 1.524)
/// a 40 s run skips its first tenth (4 s > 3.5 s), a 5 s run is cut at half (2.5 s < 3.5 s) with a
/// warning on stderr and in the summary naming the `t_end` that would do (7.03 s).
#[test]
fn the_transient_skipped_follows_the_slowest_mode_and_a_short_run_is_warned() {
    let dir = std::env::temp_dir().join(format!("random_cli_{}_transient", std::process::id()));
    let scenario = root().join("scenarios/random_damper.toml");
    let run = |t_end: &str| {
        let out = dir.join(t_end).display().to_string();
        let set = format!("integrator.t_end={t_end}");
        let (code, _, err) = damper(&[
            "simulate",
            scenario.to_str().unwrap(),
            "--set",
            &set,
            "-o",
            &out,
            "--quiet",
        ]);
        assert_eq!(code, 0, "{err}");
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(format!("{out}/summary.json")).unwrap())
                .unwrap();
        (s["random"].clone(), err)
    };
    // The smallest decay rate of the first 10 modes, from `damper linearize`.
    let (code, out, err) = damper(&[
        "linearize",
        scenario.to_str().unwrap(),
        "--json",
        "--modes",
        "10",
    ]);
    assert_eq!(code, 0, "{err}");
    let lin: serde_json::Value = serde_json::from_str(&out).unwrap();
    let sigma = lin["modes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["decay_rate"].as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    let (r, err) = run("5");
    assert!((r["slowest_decay_rate"].as_f64().unwrap() - sigma).abs() < 1e-9 * sigma);
    assert_eq!(r["from"].as_f64(), Some(2.5));
    let w = r["warning"].as_str().unwrap();
    let need = format!("t_end = {:.3} s", 2.0 * 5.0 / sigma);
    assert!(w.contains(&need), "{w} lacks {need}");
    assert!(err.contains("warning: the slowest mode decays"), "{err}");
    let (r, err) = run("40");
    assert_eq!(r["from"].as_f64(), Some(4.0));
    assert!(
        r.get("warning").is_none() && !err.contains("warning"),
        "{err}"
    );
}

/// Issue #29: the optimal load under noise. The same single degree of freedom with a
/// viscous damper `c_s` on the arm beside the generator (armature `R_a`, no inductance, its
/// damping at the arm `c_e = kappa^2 / (R_a + R_L)`, `kappa = n k_t` with `k_e = k_t`): the
/// input power `P_in = G / (4 J)` does not depend on the damping, the generator takes
/// `c_e / (c_s + c_e)` of it and the load `R_L / (R_a + R_L)` of that:
///
/// ```text
/// P_L = P_in kappa^2 R_L / (c_s (R_a + R_L)^2 + kappa^2 (R_a + R_L))
/// dP_L/dR_L = 0  <=>  R_L^2 = R_a^2 + R_a kappa^2 / c_s
/// ```
///
/// `optimize --maximize random.load_power` over `R_L` returns `R_L*` to 1e-6, and the figure
/// equals the closed form `P_L` there to 1e-9.
#[test]
fn the_optimal_load_under_noise_is_the_closed_form() {
    const RA: f64 = 1.5;
    const CS: f64 = 2e-3;
    let text = sdof_text(10.0).replace(
        "[[force]]\nname = \"generator\"",
        &format!(
            "[[force]]\nname = \"arm_damper\"\nmechanism = \"absorber\"\njoint = \"arm\"\nkind = \"damper\"\nc = {CS:e}\n\n[[force]]\nname = \"generator\""
        ),
    );
    assert!(text.contains("arm_damper"), "the damper is added");
    let p = scenario_file("optimal_load", &text);
    let (_, j) = sdof_constants();
    let kappa2 = (N * KT).powi(2);
    let best = (RA * RA + RA * kappa2 / CS).sqrt();
    let p_in = G / (4.0 * j);
    let closed = |rl: f64| p_in * kappa2 * rl / (CS * (RA + rl).powi(2) + kappa2 * (RA + rl));
    let r = json(&[
        "optimize",
        &p,
        "--vary",
        "force[2].load_resistance=0.5:20",
        "--maximize",
        "random.load_power",
        "--json",
    ]);
    let rl = r["optimum"][0][1].as_f64().unwrap();
    let value = r["objective"][1].as_f64().unwrap();
    println!(
        "R_L* = {best:.12}, optimize {rl:.12} ({:.2e} relative); P_L {value:.6e} W, closed form {:.6e} W",
        (rl / best - 1.0).abs(),
        closed(rl)
    );
    assert_eq!(r["objective"][0], "random.load_power");
    assert!((rl / best - 1.0).abs() < 1e-6, "{rl} vs {best}");
    assert!(
        (value / closed(rl) - 1.0).abs() < 1e-9,
        "{value} vs {}",
        closed(rl)
    );
}

/// The value of the figure `name` of an evaluated sweep point.
fn value_of(point: &codegen_cli::sweep_point::Evaluated, name: &str) -> f64 {
    point
        .figures
        .iter()
        .find(|f| f.name == name)
        .and_then(|f| f.value)
        .unwrap_or_else(|| panic!("no figure {name}"))
}

/// Issue #29: `random.toggle_rate:MECHANISM`, Rice's one-sided rate of up-crossings of the
/// reach `a` by the attachment's displacement, `(1/2π)(σ_v/σ_x) exp(-a²/2σ_x²)`, against
/// the up-crossings of `a` counted in a long seeded realisation of the same linear system
/// (`scenarios/random_damper.toml` under 400 times its PSD: the reach about 1.5 RMS of the
/// tip's motion, so the tip crosses it about twice a second).
///
/// The realisation is the exact discretisation `x_{k+1} = Φ x_k + w_k`, `Φ = exp(A Δt)`,
/// `w_k` Gaussian of covariance `P - Φ P Φᵀ` (P the stationary covariance of the ideal white
/// noise, so the sampled process is exactly the stationary one), started in the stationary
/// distribution, 250 s, fixed seed — of the state on the modal basis of the first 4 modes
/// (and the force's static response), whose tip σ_x and σ_v are the full model's to 1e-3
/// (checked), so that Δt can be 20 µs: the tip's velocity is driven by the white noise
/// directly (the first mode is damped at ζ ≈ 0.3), so crossings shorter than a sample are
/// missed in proportion to `sqrt(4 ζ ω Δt)`, 15 % at 1 ms, 2 % here. The count N is compared
/// with the figure's rate times the duration within 3√N (three standard deviations of the
/// count were the crossings a Poisson process; they cluster little at this damping) plus the
/// reduced model's own difference of rate.
#[test]
fn the_toggle_rate_is_the_rate_of_reach_crossings_of_a_seeded_realisation() {
    use codegen_cli::sweep_point::{PointOptions, evaluate};
    use hybrid_core::hybrid::{EigenMethod, ExcitationTarget, StateOutput, StateSpace, modes};
    use nalgebra::{DMatrix, DVector};
    let path = root().join("scenarios/random_damper.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("psd = 1e-4,", "psd = 4e-2,");
    assert!(text.contains("psd = 4e-2,"));
    let point = evaluate(&path, &text, &[], &PointOptions::default()).unwrap();
    let figure = |name: &str| value_of(&point, name);
    let rate = figure("random.toggle_rate:damper");
    let reach_sigma = figure("random.reach_sigma:damper");
    assert!((1.2..2.5).contains(&reach_sigma), "{reach_sigma}");
    // The linear system of the point, its tip output and the noise's intensity G/2.
    let file = path.display().to_string();
    let loaded = codegen_cli::scenario::parse_with(&text, &path, &[]).unwrap();
    let (input, lin) = codegen_cli::linear::linearise_scenario(&file, &loaded.scenario).unwrap();
    let limit = &codegen_cli::linear::LoadLimit::of(&input.model, &lin)[0];
    let a = limit.reach;
    let excitation = &input.model.excitations[0];
    let fem_beam::TimeFunction::WhiteNoise { psd, .. } = excitation.time else {
        panic!("white noise expected")
    };
    let force = lin.force_vector(&excitation.target);
    let first = modes(&lin, 4, EigenMethod::Dense).unwrap();
    let basis = StateSpace::modal_basis(&lin, &first, std::slice::from_ref(&force)).unwrap();
    let ss = StateSpace::new(&lin, &[force], Some(basis)).unwrap();
    let target = ExcitationTarget::Beam(limit.point.clone());
    let c = ss.row(&StateOutput::position(lin.force_vector(&target)));
    let cv = ss.row(&StateOutput::rate(lin.force_vector(&target)));
    let (p, _) = ss.covariance(&[0.5 * psd]).unwrap();
    let sigma = (c.transpose() * &p * &c)[(0, 0)].sqrt();
    let sigma_v = (cv.transpose() * &p * &cv)[(0, 0)].sqrt();
    assert!(
        (a / sigma - reach_sigma).abs() < 1e-3 * reach_sigma,
        "{} vs {reach_sigma}",
        a / sigma
    );
    let reduced = sigma_v / sigma * (-a * a / (2.0 * sigma * sigma)).exp() / std::f64::consts::TAU;
    assert!((reduced - rate).abs() < 1e-2 * rate, "{reduced} vs {rate}");
    // The exact discretisation and its noise's square root (from the symmetric eigen-solution:
    // the covariance is positive semi-definite up to rounding).
    let dt = 2e-5;
    let phi = (&ss.a * dt).exp();
    let root_of = |m: DMatrix<f64>| {
        let m = (&m + m.transpose()) * 0.5;
        let e = m.symmetric_eigen();
        &e.eigenvectors * DMatrix::from_diagonal(&e.eigenvalues.map(|v| v.max(0.0).sqrt()))
    };
    let l = root_of(&p - &phi * &p * phi.transpose());
    let n = ss.a.nrows();
    let mut rng = mbs_symbolic::samples::SplitMix64::new(2029);
    let mut gauss = |v: &mut DVector<f64>| {
        for k in (0..n).step_by(2) {
            let (u1, u2) = (1.0 - rng.next_f64(), rng.next_f64());
            let r = (-2.0 * u1.ln()).sqrt();
            let t = std::f64::consts::TAU * u2;
            v[k] = r * t.cos();
            if k + 1 < n {
                v[k + 1] = r * t.sin();
            }
        }
    };
    let mut xi = DVector::zeros(n);
    gauss(&mut xi);
    let mut x = root_of(p.clone()) * &xi;
    let mut next = DVector::zeros(n);
    let duration = 250.0;
    let steps = (duration / dt) as usize;
    let (mut crossings, mut y_prev) = (0usize, c.dot(&x));
    for _ in 0..steps {
        gauss(&mut xi);
        next.gemv(1.0, &phi, &x, 0.0);
        next.gemv(1.0, &l, &xi, 1.0);
        std::mem::swap(&mut x, &mut next);
        let y = c.dot(&x);
        if y_prev < a && y >= a {
            crossings += 1;
        }
        y_prev = y;
    }
    let expected = rate * duration;
    let tolerance = 3.0 * (crossings as f64).sqrt() + (reduced - rate).abs() * duration;
    println!(
        "reach/sigma {reach_sigma:.4}: toggle rate {rate:.4}/s (reduced model {reduced:.4}/s), {expected:.1} crossings expected in {duration} s, {crossings} counted (tolerance {tolerance:.1})"
    );
    assert!(crossings > 300, "{crossings}");
    assert!(
        (crossings as f64 - expected).abs() <= tolerance,
        "{crossings} crossings counted, {expected:.1} expected"
    );
}

/// Issue #29: the random figures of a sweep point (white noise: from the point's complete
/// modal decomposition, shared with the linear figures, not the Lyapunov equation's Schur
/// form) equal `damper random --method quadrature` (the PSD integrated over [0, ∞) on the
/// pencil, relative error estimate 1e-10) to 1e-8, and `damper random`'s dense Lyapunov
/// solution to 1e-9, at three designs of the paper's damper.
#[test]
fn random_figures_of_a_point_equal_the_quadrature_and_the_lyapunov_solution() {
    use codegen_cli::sweep_point::{PointOptions, evaluate_with};
    let path = root().join("scenarios/random_damper.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    for (angle, load) in [("6", "0.5"), ("10", "3.5"), ("20", "15")] {
        let sets = [
            format!("mechanism[0].placement.half_angle_deg={angle}"),
            format!("force[0].load_resistance={load}"),
        ];
        let overrides: Vec<codegen_cli::scenario::Override> =
            sets.iter().map(|s| s.parse().unwrap()).collect();
        let point = evaluate_with(
            &path,
            &text,
            &overrides,
            &PointOptions::default(),
            &["random.rms:1.0".to_string()],
        )
        .unwrap();
        let figure = |name: &str| value_of(&point, name);
        for (method, tol) in [("quadrature", 1e-8), ("dense", 1e-9)] {
            let mut args = vec![
                "random",
                "scenarios/random_damper.toml",
                "--json",
                "--method",
                method,
                "--output",
                "1.0",
            ];
            for s in &sets {
                args.extend(["--set", s.as_str()]);
            }
            let r = json(&args);
            let g = &r["generators"][0];
            let pairs = [
                ("random.rms:1.0", r["outputs"][0]["rms"].as_f64().unwrap()),
                (
                    "random.rms_current:generator",
                    g["rms_current"].as_f64().unwrap(),
                ),
                ("random.load_power", g["mean_power_load"].as_f64().unwrap()),
                ("random.power", g["mean_power_dissipated"].as_f64().unwrap()),
            ];
            for (name, reference) in pairs {
                let v = figure(name);
                let err = (v - reference).abs() / reference;
                println!(
                    "{angle} deg, {load} ohm, {name}: {v:e} vs {method} {reference:e}: {err:e}"
                );
                assert!(
                    err < tol,
                    "{angle} deg, {load} ohm, {name}: {v} vs {method} {reference}: {err:e}"
                );
            }
        }
    }
}

/// The response spectra of a seeded run (`random_psd.csv`, issue #32) against the linear
/// prediction, on the bundled tip-force scenario (65 s, 58.5 s stationary: 16 averages of
/// 2^16 steps, 0.153 Hz): around the first two modes (the prediction's peak bin and five
/// bins either side) the estimate's band sum is the prediction's within 3 standard errors
/// (the sum's error from the per-bin `ε` and the Hann bins' correlations 4/9 and 1/36,
/// weighted by the prediction), for every output; `∫ estimate df` is the summary's
/// stationary variance within 3 of its batch-means standard errors; and the prediction is
/// `|H|² G` of `damper frf` at the same frequencies (the same receptance, to 1e-12).
#[test]
fn the_response_psd_of_a_run_is_the_linear_prediction_within_its_error() {
    let p = "scenarios/random_damper.toml";
    let out = std::env::temp_dir().join(format!("random_cli_{}_psd_out", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let (code, stdout, err) = damper(&["simulate", p, "-o", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{stdout} {err}");
    assert!(
        stdout.contains("response PSD: 16 averages of 65536 samples (resolution 0.1526 Hz")
            && stdout.contains("beside the linear prediction"),
        "{stdout}"
    );
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let r = &summary["random"];
    let psd = &r["psd"];
    assert_eq!(psd["file"], "random_psd.csv");
    assert_eq!(psd["segment_samples"], 65536);
    assert_eq!(psd["averages"], 16);
    assert_eq!(psd["prediction"], true);
    assert_eq!(psd["sampling_hz"].as_f64().unwrap(), 1e4);
    let eps = psd["relative_standard_error"].as_f64().unwrap();
    // K = 16, Hann at half overlap: sqrt((1 + 2 (15/16) / 36) / 16).
    assert!((eps - ((1.0 + 2.0 * (15.0 / 16.0) / 36.0) / 16.0f64).sqrt()).abs() < 1e-12);
    let text = std::fs::read_to_string(out.join("random_psd.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 65536 / 2 + 1);
    assert_eq!(header[0], "f [Hz]");
    assert_eq!(header[1], "w(x=1) estimate [m^2/Hz]");
    assert_eq!(header[2], "w(x=1) prediction [m^2/Hz]");
    assert_eq!(header[header.len() - 1], "relative standard error [-]");
    let f: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let df = f[1];
    assert_eq!(df, 1e4 / 65536.0);
    let column = |c: usize| rows.iter().map(|r| r[c]).collect::<Vec<f64>>();
    let rho = |d: usize| match d {
        0 => 1.0,
        1 => 4.0 / 9.0,
        2 => 1.0 / 36.0,
        _ => 0.0,
    };
    let rms: std::collections::BTreeMap<String, [f64; 2]> = r["outputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| {
            (
                o["name"].as_str().unwrap().to_string(),
                [
                    o["rms"]["value"].as_f64().unwrap(),
                    o["rms"]["standard_error"].as_f64().unwrap(),
                ],
            )
        })
        .collect();
    let mut outputs = 0;
    for c in (1..header.len() - 1).step_by(2) {
        let name = header[c].rsplit_once(" estimate").unwrap().0;
        assert!(header[c + 1].starts_with(&format!("{name} prediction [")));
        let (est, pred) = (column(c), column(c + 1));
        for (lo, hi) in [(3.0, 10.0), (30.0, 50.0)] {
            let k = (0..f.len())
                .filter(|&j| f[j] > lo && f[j] < hi)
                .max_by(|&a, &b| pred[a].total_cmp(&pred[b]))
                .unwrap();
            let band = k - 5..=k + 5;
            let e: f64 = band.clone().map(|j| est[j]).sum();
            let s: f64 = band.clone().map(|j| pred[j]).sum();
            let var: f64 = band
                .clone()
                .flat_map(|a| band.clone().map(move |b| (a, b)))
                .map(|(a, b)| pred[a] * pred[b] * rho(a.abs_diff(b)))
                .sum();
            let se = eps * var.sqrt() / s;
            println!(
                "{name} at {:.3} Hz: estimate / prediction - 1 = {:+.4} (standard error {se:.4})",
                f[k],
                e / s - 1.0
            );
            assert!((e / s - 1.0).abs() < 3.0 * se, "{name} at {} Hz", f[k]);
        }
        if let Some([value, se]) = rms.get(name) {
            let integral: f64 = est.iter().sum::<f64>() * df;
            let (variance, se) = (value * value, 2.0 * value * se);
            println!(
                "{name}: ∫ estimate df = {integral:.4e}, stationary variance {variance:.4e} ± {se:.1e}"
            );
            assert!((integral - variance).abs() < 3.0 * se, "{name}");
        }
        outputs += 1;
    }
    assert_eq!(outputs, 8);
    // The prediction is the receptance of `damper frf` squared times G = 1e-4 N²/Hz.
    let (k1, k2) = (39, 249);
    let frf_out = out.join("frf");
    let (code, _, err) = damper(&[
        "frf",
        p,
        "--output",
        "1.0",
        "--from",
        &f[k1].to_string(),
        "--to",
        &f[k2].to_string(),
        "--points",
        "2",
        "-o",
        frf_out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let frf = std::fs::read_to_string(frf_out.join("frf.csv")).unwrap();
    let pred = column(2);
    for (line, k) in frf.lines().skip(1).zip([k1, k2]) {
        let h: f64 = line.split(',').nth(1).unwrap().parse().unwrap();
        assert!(
            (h * h * 1e-4 / pred[k] - 1.0).abs() < 1e-12,
            "{} Hz: {h} against {}",
            f[k],
            pred[k]
        );
    }
    std::fs::remove_dir_all(&out).unwrap();
}

/// A run whose stationary part is too short for 16 averages of the shortest segment writes
/// no spectrum: no `random_psd.csv`, no `psd` block.
#[test]
fn a_run_too_short_for_a_spectrum_writes_none() {
    let p = "scenarios/random_damper.toml";
    let out = std::env::temp_dir().join(format!("random_cli_{}_psd_short", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    // 0.02 s: 200 steps, the stationary part from 0.01 s (half the run), 101 samples.
    let (code, stdout, err) = damper(&[
        "simulate",
        p,
        "--set",
        "integrator.t_end=0.02",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stdout} {err}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert!(summary["random"].is_object());
    assert!(summary["random"].get("psd").is_none());
    assert!(!out.join("random_psd.csv").exists());
    assert!(!out.join("random_psd.svg").exists());
    assert!(!stdout.contains("response PSD"), "{stdout}");
    std::fs::remove_dir_all(&out).unwrap();
}
