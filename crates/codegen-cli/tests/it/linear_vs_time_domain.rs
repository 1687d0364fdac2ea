//! The linearised first mode (`damper linearize`) against the time domain (`damper simulate`,
//! its decay read through the first mode's modal filter) for the bundled hybrid scenarios,
//! through the command line (issue #11, "Verified by"). The paper's damper at 20 and 10
//! degrees is hybrid-core's `linear_vs_time_domain` test.

use crate::common;

use common::damper;

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
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
