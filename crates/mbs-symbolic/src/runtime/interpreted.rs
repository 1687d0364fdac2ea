//! The interpreted backend: the symbolic equations of a model read at run time, evaluated
//! by the DAG interpreter ([`crate::expr::Tape`]) — the same expressions the generator
//! emits, without generating code.

use crate::constraints;
use crate::expr::{EvalInput, Id, Tape};
use crate::model::Model;

use super::system::{
    Backend, ElementPower, Names, ParamError, System, Workspace, bias_entry, store_bias,
};

/// The symbolic equations of a model evaluated by the DAG interpreter: complete — `M`, `F`,
/// `Q`, `h`, `J`, `A` (one tape), `h`, `J` (the position-level tape), `V`, and the
/// kinematics of every named point (one tape each). Allocation-free once the workspace
/// exists (the tapes evaluate into [`Workspace::scratch`]).
#[derive(Clone, Debug)]
pub struct InterpretedSystem {
    n: usize,
    rows: usize,
    all: Tape,
    positions: Tape,
    potential: Tape,
    /// Outputs `D`, `P` of the force elements.
    power: Tape,
    /// `G = dF^b/dg`, row-major `n x 3`.
    gravity: Tape,
    /// Whether the model has force elements.
    force_elements: bool,
    point_tapes: Vec<Tape>,
    values: Vec<f64>,
    names: Names,
    param_index: Vec<usize>,
}

impl InterpretedSystem {
    /// Derives the model symbolically (Newton–Euler, constraints, points) and compiles the
    /// tapes. Folded parameters take their values from `model`; run-time parameters start at
    /// their defaults.
    pub fn new(model: &Model) -> InterpretedSystem {
        let (sym, cons, pts) = constraints::derive_all(model);
        let n = sym.n;
        let rows = cons.h.len();
        let mut outs: Vec<Id> = Vec::with_capacity(n * n + 2 * n + rows * (n + 2));
        outs.extend(&sym.mass);
        outs.extend(&sym.f);
        outs.extend(&sym.q);
        let pos_start = outs.len();
        outs.extend(&cons.h);
        for row in &cons.j {
            outs.extend(row);
        }
        let pos_end = outs.len();
        outs.extend(&cons.a);
        let point_tapes = pts
            .iter()
            .map(|pt| {
                let mut o: Vec<Id> = pt.p.to_vec();
                for row in &pt.j {
                    o.extend(row);
                }
                o.extend(pt.a.to_vec());
                Tape::new(&sym.dag, &o)
            })
            .collect();
        let (names, param_index) = Names::of(model);
        InterpretedSystem {
            n,
            rows,
            all: Tape::new(&sym.dag, &outs),
            positions: Tape::new(&sym.dag, &outs[pos_start..pos_end]),
            potential: Tape::new(&sym.dag, &[sym.potential]),
            power: Tape::new(&sym.dag, &[sym.dissipation, sym.input_power]),
            gravity: Tape::new(&sym.dag, &sym.gravity_jacobian),
            force_elements: !model.forces.is_empty(),
            point_tapes,
            values: model.default_params(),
            names,
            param_index,
        }
    }

    fn input<'a>(&'a self, q: &'a [f64], qd: &'a [f64], t: f64) -> EvalInput<'a> {
        EvalInput {
            q,
            qd,
            qdd: &[],
            t,
            params: &self.values,
        }
    }

    /// Runs `tape` with its outputs in the tail of the workspace scratch, then hands the
    /// outputs and the rest of the workspace to `read`.
    fn run(
        &self,
        tape: &Tape,
        q: &[f64],
        qd: &[f64],
        t: f64,
        ws: &mut Workspace,
        read: impl FnOnce(&[f64], &mut Workspace),
    ) {
        let need = tape.scratch_len() + tape.output_len();
        if ws.scratch.len() < need {
            // Only a workspace not made by `workspace()` is too short.
            ws.scratch.resize(need, 0.0);
        }
        let mut scratch = std::mem::take(&mut ws.scratch);
        let (slots, rest) = scratch.split_at_mut(tape.scratch_len());
        let out = &mut rest[..tape.output_len()];
        tape.eval(&self.input(q, qd, t), slots, out);
        read(out, ws);
        ws.scratch = scratch;
    }

    /// Copies `h` and `J` from tape outputs.
    fn copy_positions(n: usize, rows: usize, out: &[f64], ws: &mut Workspace) {
        for r in 0..rows {
            ws.h[r] = out[r];
            for c in 0..n {
                ws.j[(r, c)] = out[rows + r * n + c];
            }
        }
    }
}

impl System for InterpretedSystem {
    fn backend(&self) -> Backend {
        Backend::Interpreted
    }
    fn dof(&self) -> usize {
        self.n
    }
    fn rows(&self) -> usize {
        self.rows
    }
    fn names(&self) -> &Names {
        &self.names
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        let k = self.param_index[self.names.param(name, value)?];
        self.values[k] = value;
        Ok(())
    }

    fn scratch_len(&self) -> usize {
        std::iter::once(&self.all)
            .chain([&self.positions, &self.potential, &self.power, &self.gravity])
            .chain(&self.point_tapes)
            .map(|t| t.scratch_len() + t.output_len())
            .max()
            .unwrap_or(0)
    }

    fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace) {
        let (n, rows) = (self.n, self.rows);
        self.run(&self.all, q, qd, t, ws, |out, ws| {
            for r in 0..n {
                for c in 0..n {
                    ws.m[(r, c)] = out[r * n + c];
                }
                ws.f[r] = out[n * n + r];
                ws.q[r] = out[n * n + n + r];
            }
            let base = n * n + 2 * n;
            Self::copy_positions(n, rows, &out[base..], ws);
            let a0 = base + rows * (n + 1);
            store_bias(&out[a0..a0 + rows], ws.a.as_mut_slice());
        });
    }

    fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace) {
        let (n, rows) = (self.n, self.rows);
        self.run(&self.positions, q, &[], 0.0, ws, |out, ws| {
            Self::copy_positions(n, rows, out, ws)
        });
    }

    fn potential_energy(&self, q: &[f64], ws: &mut Workspace) -> f64 {
        let mut v = 0.0;
        self.run(&self.potential, q, &[], 0.0, ws, |out, _| v = out[0]);
        v
    }

    fn gravity_load_jacobian(&self, q: &[f64], ws: &mut Workspace) {
        let n = self.n;
        self.run(&self.gravity, q, &[], 0.0, ws, |out, ws| {
            for r in 0..n {
                for c in 0..3 {
                    ws.gravity_jacobian[(r, c)] = out[3 * r + c];
                }
            }
        });
    }

    fn has_force_elements(&self) -> bool {
        self.force_elements
    }

    fn element_power(&self, q: &[f64], qd: &[f64], ws: &mut Workspace) -> ElementPower {
        let mut p = ElementPower::default();
        self.run(&self.power, q, qd, 0.0, ws, |out, _| {
            p = ElementPower {
                dissipated: out[0],
                input: out[1],
            }
        });
        p
    }

    fn point_kinematics(&self, k: usize, q: &[f64], qd: &[f64], ws: &mut Workspace) -> bool {
        let Some(tape) = self.point_tapes.get(k) else {
            return false;
        };
        let n = self.n;
        self.run(tape, q, qd, 0.0, ws, |out, ws| {
            for r in 0..3 {
                ws.point_p[r] = out[r];
                for c in 0..n {
                    ws.point_j[(r, c)] = out[3 + r * n + c];
                }
                ws.point_a[r] = bias_entry(out[3 + 3 * n + r]);
            }
        });
        true
    }

    fn clone_box(&self) -> Box<dyn System> {
        Box::new(self.clone())
    }
}
