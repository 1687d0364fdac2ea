//! Eigenvalue and harmonic-response sensitivities (issue #22,
//! [`hybrid_core::hybrid::EigenSensitivity`]): the adjoint derivative of the first
//! eigenvalue equals central differences of independently computed eigenvalues (the
//! eigen-solver run at `p +- H`) for the load resistance (which enters the damping only),
//! the half-angle (which moves the static equilibrium and every block of the pencil) and a
//! synthetic perturbation whose pencil derivative is exact; the left vector is a left null
//! vector; the response derivative equals central differences of the responses.

use crate::common;

use common::*;
use hybrid_core::generator::GeneratorSpec;
use hybrid_core::hybrid::{
    BeamPoint, EigenMethod, EigenSensitivity, EquilibriumOptions, ExcitationTarget, ForceKind,
    HybridModel, Linearization, Pencil, modes, pencil_derivative, response_derivative,
};
use nalgebra::Complex;

type C64 = Complex<f64>;

fn linearize(model: &HybridModel) -> Linearization {
    let t = tangents(model, &[]);
    let refs: Vec<_> = t.iter().collect();
    Linearization::new(model, &refs, EquilibriumOptions::default()).unwrap()
}

fn first_lambda(lin: &Linearization) -> C64 {
    modes(lin, 1, EigenMethod::Auto).unwrap()[0].lambda()
}

fn set_load(model: &mut HybridModel, r: f64) {
    for f in &mut model.forces {
        if let ForceKind::Generator(GeneratorSpec {
            load_resistance, ..
        }) = &mut f.kind
        {
            *load_resistance = r;
        }
    }
}

/// The paper's damper with load resistance `r` and inductance `l` at half-angle `deg`.
fn damper(r: f64, l: f64, deg: f64) -> HybridModel {
    let (mut model, _) = paper_damper_at(20, true, true, l, deg);
    set_load(&mut model, r);
    model
}

/// The adjoint derivative at `p` against central differences of the eigenvalues (Richardson
/// extrapolated from steps `H` and `2H`, truncation `O(H^4)`).
fn check(name: &str, p: f64, build: &dyn Fn(f64) -> HybridModel, tol: f64) {
    let lin = linearize(&build(p));
    let mode = &modes(&lin, 1, EigenMethod::Auto).unwrap()[0];
    let sens = EigenSensitivity::new(&lin, mode).unwrap();
    // The left vector: psi^T S(lambda) = 0 (backward error of the transposed pair).
    let t = lin.transposed();
    let r = t.pencil_mul(sens.lambda(), sens.left());
    let scale = lin.norm_bound(hybrid_core::hybrid::Matrix::Stiffness);
    let rl = r.iter().map(|x| x.norm()).fold(0.0, f64::max) / scale;
    let h = 1e-6 * p.abs().max(1e-3);
    let (plus, minus) = (linearize(&build(p + h)), linearize(&build(p - h)));
    let adjoint = sens
        .derivative_over(&[(0.5 / h, &plus), (-0.5 / h, &minus)])
        .unwrap();
    let big = 1e-3 * p.abs().max(1e-3);
    let fd = |s: f64| {
        (first_lambda(&linearize(&build(p + s))) - first_lambda(&linearize(&build(p - s))))
            / (2.0 * s)
    };
    let reference = (fd(big) * 4.0 - fd(2.0 * big)) / 3.0;
    let err = (adjoint - reference).norm() / reference.norm();
    println!(
        "{name}: lambda {}, dlambda/dp adjoint {adjoint}, differences {reference}, relative {err:e}, left residual {rl:e}",
        sens.lambda()
    );
    assert!(rl < 1e-12, "{name}: left residual {rl:e}");
    assert!(err < tol, "{name}: {err:e}");
}

#[test]
fn first_eigenvalue_derivatives_equal_central_differences_of_the_eigenvalues() {
    // Load resistance, generator without and with inductance (a damper in C_R; a current
    // state in the pencil's rational term).
    check("R_L (L = 0)", 3.5, &|r| damper(r, 0.0, 10.0), 1e-7);
    check("R_L (L = 2 mH)", 3.5, &|r| damper(r, 2e-3, 10.0), 1e-7);
    // Half-angle: equilibrium, geometry, amplification and every block move.
    check("half-angle", 10.0, &|deg| damper(3.5, 2e-3, deg), 1e-7);
    // An overdamped first mode (gear ratio 20 at 4 degrees: a real eigenvalue).
    let geared = |r: f64| {
        let mut model = damper(r, 0.0, 4.0);
        for f in &mut model.forces {
            if let ForceKind::Generator(g) = &mut f.kind {
                g.gear_ratio = 20.0;
            }
        }
        model
    };
    let lin = linearize(&geared(0.5));
    assert_eq!(
        modes(&lin, 1, EigenMethod::Auto).unwrap()[0].kind,
        hybrid_core::hybrid::ModeKind::Overdamped
    );
    check("R_L overdamped", 0.5, &geared, 1e-7);
}

/// A perturbation whose pencil derivative is exact (the stiffness and mass blocks scaled
/// linearly): no differences in the derivative, so the adjoint formula itself is checked
/// against the eigen-solver to the accuracy of the differences of eigenvalues.
#[test]
fn the_adjoint_formula_is_exact_for_an_exact_pencil_derivative() {
    let lin = linearize(&damper(3.5, 2e-3, 10.0));
    let scaled = |t: f64| {
        let mut l = lin.clone();
        l.ks += lin.ks.clone() * t;
        l.ms -= lin.ms.clone() * (0.5 * t);
        l
    };
    let mode = &modes(&lin, 1, EigenMethod::Auto).unwrap()[0];
    let sens = EigenSensitivity::new(&lin, mode).unwrap();
    // dS/dt (lambda) phi = P^T (K_s - lambda^2 M_s / 2) P phi, exactly (the difference of an
    // affine function).
    let l = sens.lambda();
    let (a, b) = (scaled(1.0), scaled(-1.0));
    let exact = pencil_derivative(&[(0.5, &a, l), (-0.5, &b, l)], sens.right()).unwrap();
    let adjoint = sens.derivative(&exact);
    let fd = |s: f64| (first_lambda(&scaled(s)) - first_lambda(&scaled(-s))) / (2.0 * s);
    let reference = (fd(1e-3) * 4.0 - fd(2e-3)) / 3.0;
    let err = (adjoint - reference).norm() / reference.norm();
    println!("synthetic: adjoint {adjoint}, differences {reference}, relative {err:e}");
    assert!(err < 1e-8, "{err:e}");
}

#[test]
fn the_response_derivative_equals_central_differences_of_the_responses() {
    let build = |deg: f64| damper(3.5, 2e-3, deg);
    let (p, h) = (10.0, 1e-5);
    let lin = linearize(&build(p));
    let (plus, minus) = (linearize(&build(p + h)), linearize(&build(p - h)));
    let beam = build(p).beam().cloned().unwrap();
    let tip = BeamPoint::on(&beam, 1.0).unwrap();
    let target = ExcitationTarget::Beam(tip.clone());
    for omega in [20.0, 37.0, 80.0] {
        let f = lin.force_vector(&target);
        let z = lin.harmonic_response(&f, omega).unwrap();
        let sigma = C64::new(0.0, omega);
        let pencil = Pencil::new(&lin, sigma).unwrap();
        let ds_z =
            pencil_derivative(&[(0.5 / h, &plus, sigma), (-0.5 / h, &minus, sigma)], &z).unwrap();
        let df: Vec<f64> = plus
            .force_vector(&target)
            .iter()
            .zip(minus.force_vector(&target))
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect();
        let dz = response_derivative(&pencil, &ds_z, &df);
        let big = 1e-3;
        let fd = |s: f64| {
            let (a, b) = (linearize(&build(p + s)), linearize(&build(p - s)));
            let za = a
                .harmonic_response(&a.force_vector(&target), omega)
                .unwrap();
            let zb = b
                .harmonic_response(&b.force_vector(&target), omega)
                .unwrap();
            (tip.complex_value(&za) - tip.complex_value(&zb)) / (2.0 * s)
        };
        let reference = (fd(big) * 4.0 - fd(2.0 * big)) / 3.0;
        let adjoint = tip.complex_value(&dz);
        let err = (adjoint - reference).norm() / reference.norm();
        println!("omega {omega}: dH/dp {adjoint} vs {reference}: {err:e}");
        assert!(err < 1e-7, "{err:e}");
    }
}
