//! The linearised first mode (`damper linearize`) against the time domain (`damper simulate`,
//! its decay read through the first mode's modal filter): damping ratio and damped frequency
//! agree within 1 % at 20 and 10 degrees at small amplitude, and the per-cycle damping stays
//! on the linear value as the amplitude shrinks (issue #11, "Verified by").

use crate::common;

use common::damper;

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn linearised_first_mode_equals_the_filtered_free_decay_at_small_amplitude() {
    let dir = std::env::temp_dir().join(format!("damper-lin-td-{}", std::process::id()));
    for angle in ["20", "10"] {
        let set_angle = format!("mechanism.half_angle_deg={angle}");
        let out = dir.join(angle);
        let out_s = out.to_str().unwrap();
        // 0.1 mm at the tip: 3 % of the double bar's reach at 10 degrees.
        let (code, _, err) = damper(&[
            "simulate",
            "scenarios/damper.toml",
            "--quiet",
            "--set",
            &set_angle,
            "--set",
            "initial.displacement=1e-4",
            "--set",
            "integrator.t_end=3",
            "--set",
            "output.compare=[]",
            "-o",
            out_s,
        ]);
        assert_eq!(code, 0, "{err}");
        let s = json(&out.join("summary.json"));
        let (code, text, err) = damper(&[
            "linearize",
            "scenarios/damper.toml",
            "--json",
            "--modes",
            "1",
            "--set",
            &set_angle,
        ]);
        assert_eq!(code, 0, "{err}");
        let lin: serde_json::Value = serde_json::from_str(&text).unwrap();
        let m = &lin["modes"][0];
        let (zeta, fd) = (
            m["damping_ratio"].as_f64().unwrap(),
            m["damped_frequency_hz"].as_f64().unwrap(),
        );
        let zt = s["zeta_with_generator"].as_f64().unwrap();
        let ft = s["frequency_with_generator_hz"].as_f64().unwrap();
        println!(
            "{angle} deg: zeta linear {zeta:.7} time {zt:.7} ({:.1e}); f_d linear {fd:.6} time {ft:.6} ({:.1e})",
            (zt - zeta).abs() / zeta,
            (ft - fd).abs() / fd
        );
        assert!((zt - zeta).abs() <= 0.01 * zeta);
        assert!((ft - fd).abs() <= 0.01 * fd);
        // Damping against amplitude: every cycle, from the largest to the smallest the
        // estimator keeps, on the linear value (a linear decay has one damping ratio).
        let cycles = s["decay_with_generator"]["cycles"].as_array().unwrap();
        assert!(cycles.len() >= 10, "{angle}: {} cycles", cycles.len());
        let first = cycles[0]["amplitude"].as_f64().unwrap();
        let last = cycles[cycles.len() - 1]["amplitude"].as_f64().unwrap();
        assert!(last < 0.3 * first, "the decay spans a range of amplitudes");
        for c in cycles {
            let z = c["zeta"].as_f64().unwrap();
            assert!(
                (z - zeta).abs() <= 0.01 * zeta,
                "{angle} deg: cycle at {} m: zeta {z} vs {zeta}",
                c["amplitude"]
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Hybrid scenarios: the free decay read through the first mode's modal filter (the absorber's
/// two close modes and the slider-crank's) gives the linearised first-mode damping: the
/// absorber within 1e-4, the others within 1 % at the bundled 1 mm amplitude.
#[test]
fn hybrid_free_decays_read_through_the_first_mode_give_its_linearised_damping() {
    let dir = std::env::temp_dir().join(format!("damper-lin-td-h-{}", std::process::id()));
    for name in ["pendulum_absorber", "slider_crank_damper", "two_dampers"] {
        let path = format!("scenarios/{name}.toml");
        let out = dir.join(name);
        let (code, _, err) = damper(&["simulate", &path, "--quiet", "-o", out.to_str().unwrap()]);
        assert_eq!(code, 0, "{err}");
        let s = json(&out.join("summary.json"));
        assert!(
            s["decay_signal"]
                .as_str()
                .unwrap()
                .starts_with("modal filter"),
            "{name}: {}",
            s["decay_signal"]
        );
        let (code, text, err) = damper(&["linearize", &path, "--json", "--modes", "1"]);
        assert_eq!(code, 0, "{err}");
        let lin: serde_json::Value = serde_json::from_str(&text).unwrap();
        let zeta = lin["modes"][0]["damping_ratio"].as_f64().unwrap();
        let zt = s["damping_ratio"].as_f64().unwrap();
        println!(
            "{name}: zeta linear {zeta:.6} time domain {zt:.6} ({:.1e})",
            (zt - zeta).abs() / zeta
        );
        // The absorber's summary reads its complex first mode exactly (the left-eigenvector
        // projection; issue 23): 1e-4. The others at their bundled 1 mm amplitude: 1 %.
        let tol = if name == "pendulum_absorber" {
            1e-4
        } else {
            0.01
        };
        assert!((zt - zeta).abs() <= tol * zeta, "{name}: {zt} vs {zeta}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
