#!/usr/bin/env python3
"""The paper's damper (scenarios/damper.toml) built and simulated in Exudyn.

A peer model for the whole-process comparison of issue #31 (see benches/peers/README.md).
Everything is built here from the scenario file and the double bar's model file, with the
formulas written out below; nothing is read from `damper`'s output.

- Beam: the clamped Euler-Bernoulli beam in cubic Hermite elements (consistent mass and
  stiffness, w and theta = w' per node), Rayleigh damping fitted to the scenario's modal
  ratios on the bare beam's FE modes; one ObjectGenericODE2 holding M, K, C. Its tip node is
  a NodePoint2D (ux, uy = w_tip) so that a joint can hold it; ux has no mass and is held at
  0 by a coordinate constraint (the linear beam has no axial motion: eq. 46).
- Double bar: crank and coupler as ObjectRigidBody2D (uniform rods, m L^2/12 about the
  centre), revolute joints ground-crank, crank-coupler, coupler-beam tip.
- Generator without inductance: the viscous torque c_g = n^2 kt ke / (Ra + RL) on the crank's
  rotation (a coordinate spring-damper of stiffness 0) and the rotor's n^2 J_r added to the
  crank's rotational inertia; current i = ke n q1' / (Ra + RL).
- Integrator: Exudyn's implicit solver, Newmark beta = 1/4, gamma = 1/2 (the trapezoidal
  rule, as the scenario's "newmark"), constraints at velocity level (index 2), or
  generalized-alpha (index 3) with --rho; Exudyn's default Newton tolerances and its
  sparse LU (EigenSparse, the beam's band passed as sparse triplets).
- Output: five sensors (tip displacement and velocity, the crank's and the coupler's
  coordinates, the crank's velocities) written to files in -o DIR every `every` steps, 17
  digits, as damper's time_history.csv; no solution file, no rendering, nothing printed
  with --quiet.
"""
import argparse
import math
import os
import sys
import time

try:
    import tomllib
except ImportError:
    sys.exit("damper.py: needs Python >= 3.11 (tomllib)")
try:
    import numpy as np
    import exudyn as exu
    from exudyn.itemInterface import (
        MarkerBodyPosition, MarkerNodeCoordinate, MarkerNodePosition, NodeGenericODE2,
        NodePoint2D, NodePointGround, NodeRigidBody2D, ObjectConnectorCoordinate, SensorMarker,
        ObjectConnectorCoordinateSpringDamper, ObjectGenericODE2, ObjectGround,
        ObjectJointRevolute2D, ObjectRigidBody2D, SensorNode)
except ImportError as e:
    sys.exit(f"damper.py: Python module {e.name!r} missing: create the venv first "
             "(benches/peers/README.md, section Exudyn)")

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", "..", ".."))


def fail(msg):
    sys.exit(f"damper.py: {msg}")


def only(table, allowed, where):
    """Refuse a field the peer does not model (rather than silently leave it out)."""
    extra = sorted(set(table) - set(allowed))
    if extra:
        fail(f"{where}: {', '.join(extra)} not modelled by the peer")


def numbers(table, where):
    for k, v in table.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            fail(f"{where}.{k}: a plain number expected (units in strings are not read here)")


def load_model(scenario_path):
    """The damper's numbers from the scenario and the mechanism file; refuses what the peer
    model does not represent."""
    with open(scenario_path, "rb") as f:
        sc = tomllib.load(f)
    only(sc, ["kind", "description", "beam", "mechanism", "generator", "initial",
              "integrator", "output"], scenario_path)
    only(sc["beam"], ["name", "segment", "support", "damping"], "[beam]")
    only(sc["generator"], ["kt", "ke", "armature_resistance", "load_resistance", "inductance",
                           "gear_ratio", "rotor_inertia"], "[generator]")
    numbers(sc["generator"], "generator")
    only(sc["initial"], ["displacement"], "[initial]")
    only(sc["integrator"], ["method", "dt", "t_end"], "[integrator]")
    only(sc["mechanism"], ["model", "point", "x", "half_angle_deg", "generator_joint",
                           "max_condition", "parameters"], "[mechanism]")
    only(sc["beam"].get("damping", {}), ["ratios"], "[beam.damping]")
    for seg in sc["beam"]["segment"]:
        only(seg, ["length", "youngs_modulus", "density", "width", "height", "elements"],
             "[[beam.segment]]")
        numbers(seg, "beam.segment")
    numbers(sc["initial"], "initial")
    numbers({k: v for k, v in sc["integrator"].items() if k != "method"}, "integrator")
    if sc.get("kind", "damper") != "damper":
        fail(f"{scenario_path}: only kind = \"damper\" is modelled")
    for key in ("excitation",):
        if key in sc:
            fail(f"{scenario_path}: [{key}] is not modelled by the peer")
    beam = sc["beam"]
    segs = beam["segment"]
    if len(segs) != 1:
        fail("one beam segment expected")
    s = segs[0]
    sup = beam["support"]
    if len(sup) != 1 or sup[0]["x"] != 0.0 or sup[0]["kind"] != "clamped":
        fail("a cantilever clamped at x = 0 expected")
    mech = sc["mechanism"]
    if mech.get("point") != "tip" or mech.get("generator_joint") != "crank":
        fail("the double bar pinned by its point tip, generator on the crank, expected")
    if abs(mech["x"] - s["length"]) > 1e-12:
        fail("the double bar pinned to the beam's free end expected")
    if "pivot" in mech:
        fail("the pivot placed by half_angle_deg expected")
    gen = sc["generator"]
    if gen.get("inductance", 0.0) != 0.0:
        fail("a generator with inductance is not modelled by the peer")
    integ = sc["integrator"]
    if integ.get("method", "newmark") != "newmark":
        fail("the Newmark integrator expected")
    model_path = os.path.normpath(os.path.join(os.path.dirname(scenario_path), mech["model"]))
    with open(model_path, "rb") as f:
        mod = tomllib.load(f)
    if mod.get("name") != "double_bar":
        fail(f"{model_path}: the double bar expected")
    par = {k: (v["value"] if isinstance(v, dict) else v) for k, v in mod["parameters"].items()}
    par.update(mech.get("parameters", {}))
    if par.get("gx", 0.0) != 0.0 or par.get("gy", 0.0) != 0.0:
        fail("gravity on the mechanism is not modelled by the peer")
    damping = beam.get("damping", {})
    ratios = damping.get("ratios", [])
    if sorted(r["mode"] for r in ratios) != [1, 2]:
        fail("Rayleigh damping by the ratios of modes 1 and 2 expected")
    return dict(
        length=s["length"], E=s["youngs_modulus"], rho=s["density"], b=s["width"],
        h=s["height"], ne=s["elements"],
        zeta={r["mode"]: r["ratio"] for r in ratios},
        L1=par["L1"], L2=par["L2"], m1=par["m1"], m2=par["m2"],
        half_angle=math.radians(mech["half_angle_deg"]),
        kt=gen["kt"], ke=gen["ke"], R=gen["armature_resistance"] + gen["load_resistance"],
        n=gen["gear_ratio"], Jr=gen["rotor_inertia"],
        w0=sc["initial"]["displacement"],
        dt=integ["dt"], t_end=integ["t_end"], every=sc.get("output", {}).get("every", 1),
    )


def beam_matrices(p):
    """Consistent mass and stiffness of the clamped beam (eqs. 38-39), coordinates
    [w1, th1, ..., w_ne, th_ne] (node 0 clamped), and the Rayleigh damping (eq. 40)."""
    ne, le = p["ne"], p["length"] / p["ne"]
    EI = p["E"] * p["b"] * p["h"] ** 3 / 12.0
    rA = p["rho"] * p["b"] * p["h"]
    l = le
    me = rA * l / 420.0 * np.array([
        [156, 22 * l, 54, -13 * l],
        [22 * l, 4 * l * l, 13 * l, -3 * l * l],
        [54, 13 * l, 156, -22 * l],
        [-13 * l, -3 * l * l, -22 * l, 4 * l * l]])
    ke = EI / l ** 3 * np.array([
        [12, 6 * l, -12, 6 * l],
        [6 * l, 4 * l * l, -6 * l, 2 * l * l],
        [-12, -6 * l, 12, -6 * l],
        [6 * l, 2 * l * l, -6 * l, 4 * l * l]])
    nd = 2 * (ne + 1)
    M = np.zeros((nd, nd))
    K = np.zeros((nd, nd))
    for e in range(ne):
        i = 2 * e
        M[i:i + 4, i:i + 4] += me
        K[i:i + 4, i:i + 4] += ke
    M, K = M[2:, 2:], K[2:, 2:]
    # generalised symmetric eigenproblem by Cholesky: K phi = w^2 M phi
    Lc = np.linalg.cholesky(M)
    Li = np.linalg.inv(Lc)
    w2 = np.linalg.eigvalsh(Li @ K @ Li.T)
    w1, w2_ = math.sqrt(w2[0]), math.sqrt(w2[1])
    z1, z2 = p["zeta"][1], p["zeta"][2]
    # zeta_i = a / (2 w_i) + b w_i / 2
    a, b = np.linalg.solve([[1 / (2 * w1), w1 / 2], [1 / (2 * w2_), w2_ / 2]], [z1, z2])
    return M, K, a * M + b * K, EI, (w1, w2_), (a, b)


def build(p, args):
    M, K, C, EI, om, ab = beam_matrices(p)
    L, ne = p["length"], p["ne"]
    n = M.shape[0]                      # 2 ne free coordinates; tip w is n-2, tip th is n-1
    # Exudyn coordinates: node A = [w1, th1, ..., w_{ne-1}, th_{ne-1}, th_ne], node B = (ux, w_ne)
    order = list(range(n - 2)) + [n - 1]
    na = len(order)
    N = na + 2
    Mx, Kx, Cx = (np.zeros((N, N)) for _ in range(3))
    idx = order + [None, n - 2]
    for I, gi in enumerate(idx):
        for J, gj in enumerate(idx):
            if gi is None or gj is None:
                continue
            Mx[I, J], Kx[I, J], Cx[I, J] = M[gi, gj], K[gi, gj], C[gi, gj]
    # initial shape: the static deflection of a tip load P scaled to w0 at the tip
    #   w = P x^2 (3L - x) / (6 EI),  th = P x (2L - x) / (2 EI),  w(L) = P L^3 / (3 EI)
    P = p["w0"] * 3 * EI / L ** 3
    q0 = np.zeros(n)
    for k in range(1, ne + 1):
        x = k * L / ne
        q0[2 * k - 2] = P * x * x * (3 * L - x) / (6 * EI)
        q0[2 * k - 1] = P * x * (2 * L - x) / (2 * EI)

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    nA = mbs.AddNode(NodeGenericODE2(referenceCoordinates=[0.0] * na,
                                     initialCoordinates=list(q0[order]),
                                     initialCoordinates_t=[0.0] * na,
                                     numberOfODE2Coordinates=na))
    nB = mbs.AddNode(NodePoint2D(referenceCoordinates=[L, 0.0],
                                 initialCoordinates=[0.0, q0[n - 2]]))
    if args.linear_solver == "EigenSparse":
        # the band as sparse triplets (zeros dropped), so the sparse Jacobian stays sparse
        def sparse(A):
            mc = exu.MatrixContainer()
            mc.SetWithDenseMatrix(A, useDenseMatrix=False)
            return mc
        Mx, Kx, Cx = sparse(Mx), sparse(Kx), sparse(Cx)
    mbs.AddObject(ObjectGenericODE2(nodeNumbers=[nA, nB], massMatrix=Mx, stiffnessMatrix=Kx,
                                    dampingMatrix=Cx))
    ground = mbs.AddObject(ObjectGround())
    nG = mbs.AddNode(NodePointGround())
    mG = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nG, coordinate=0))
    # eq. 46: the pinned point keeps its abscissa (no axial motion of the linear beam)
    mBx = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nB, coordinate=0))
    mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[mG, mBx]))

    # double bar: pivot G on the tip's line of motion, d = L1 cos a + sqrt(L2^2 - L1^2 sin^2 a)
    # below the undeformed tip; knee on the clockwise side (crank angle pi/2 - alpha)
    L1, L2, m1, m2 = p["L1"], p["L2"], p["m1"], p["m2"]
    a0 = p["half_angle"]
    d0 = L1 * math.cos(a0) + math.sqrt(L2 ** 2 - (L1 * math.sin(a0)) ** 2)
    G = np.array([L, -d0])
    tip = np.array([L, q0[n - 2]])
    D = tip[1] - G[1]
    a = math.acos((L1 ** 2 + D ** 2 - L2 ** 2) / (2 * L1 * D))
    phi1 = math.pi / 2 - a
    knee = G + L1 * np.array([math.cos(phi1), math.sin(phi1)])
    phi2 = math.atan2(tip[1] - knee[1], tip[0] - knee[0])
    c1 = G + 0.5 * L1 * np.array([math.cos(phi1), math.sin(phi1)])
    c2 = knee + 0.5 * L2 * np.array([math.cos(phi2), math.sin(phi2)])
    n2Jr = p["n"] ** 2 * p["Jr"]
    nC1 = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[c1[0], c1[1], phi1]))
    nC2 = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[c2[0], c2[1], phi2]))
    b1 = mbs.AddObject(ObjectRigidBody2D(nodeNumber=nC1, mass=m1,
                                         inertia=m1 * L1 ** 2 / 12 + n2Jr))
    b2 = mbs.AddObject(ObjectRigidBody2D(nodeNumber=nC2, mass=m2, inertia=m2 * L2 ** 2 / 12))
    mGp = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[G[0], G[1], 0]))
    m1a = mbs.AddMarker(MarkerBodyPosition(bodyNumber=b1, localPosition=[-L1 / 2, 0, 0]))
    m1b = mbs.AddMarker(MarkerBodyPosition(bodyNumber=b1, localPosition=[L1 / 2, 0, 0]))
    m2a = mbs.AddMarker(MarkerBodyPosition(bodyNumber=b2, localPosition=[-L2 / 2, 0, 0]))
    m2b = mbs.AddMarker(MarkerBodyPosition(bodyNumber=b2, localPosition=[L2 / 2, 0, 0]))
    mBp = mbs.AddMarker(MarkerNodePosition(nodeNumber=nB))
    mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[mGp, m1a]))
    mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[m1b, m2a]))
    mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[m2b, mBp]))
    # generator without inductance: viscous torque -c_g q1' on the crank (section 7)
    cg = p["n"] ** 2 * p["kt"] * p["ke"] / p["R"]
    mC1 = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nC1, coordinate=2))
    mbs.AddObject(ObjectConnectorCoordinateSpringDamper(markerNumbers=[mG, mC1],
                                                        stiffness=0.0, damping=cg))

    sensors = {}
    out = args.out
    for name, node, ovt in (("tip_displacement", nB, exu.OutputVariableType.Displacement),
                            ("tip_velocity", nB, exu.OutputVariableType.Velocity),
                            ("crank", nC1, exu.OutputVariableType.Coordinates),
                            ("crank_rate", nC1, exu.OutputVariableType.Coordinates_t),
                            ("coupler", nC2, exu.OutputVariableType.Coordinates)):
        fn = os.path.join(out, name + ".txt") if out else ""
        sensors[name] = mbs.AddSensor(SensorNode(nodeNumber=node, outputVariableType=ovt,
                                                 writeToFile=bool(out), fileName=fn,
                                                 storeInternal=args.internal))
    if args.internal:
        # the drift of the velocity-level constraints: the coupler's end against the beam tip
        sensors["coupler_end"] = mbs.AddSensor(SensorMarker(
            markerNumber=m2b, outputVariableType=exu.OutputVariableType.Position,
            writeToFile=False, storeInternal=True))
        sensors["tip_position"] = mbs.AddSensor(SensorMarker(
            markerNumber=mBp, outputVariableType=exu.OutputVariableType.Position,
            writeToFile=False, storeInternal=True))
    mbs.Assemble()
    info = dict(omega=om, rayleigh=ab, cg=cg, n2Jr=n2Jr, q1_0=phi1, q2_0=phi2 - phi1,
                ncoords=N + 6)
    return sc, mbs, sensors, info


def simulate(mbs, p, args):
    dt = args.dt if args.dt else p["dt"]
    t_end = args.t_end if args.t_end else p["t_end"]
    every = args.every if args.every else p["every"]
    steps = round(t_end / dt)
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.numberOfSteps = steps
    ti.endTime = t_end
    ti.verboseMode = 0
    ti.stepInformation = 0
    ga = ti.generalizedAlpha
    if args.rho is None:
        ga.useNewmark = True
        ga.newmarkBeta = 0.25
        ga.newmarkGamma = 0.5
        ga.useIndex2Constraints = True
    else:
        ga.useNewmark = False
        ga.spectralRadius = args.rho
        ga.useIndex2Constraints = False   # Exudyn's generalized-alpha: index 3 only
    ga.computeInitialAccelerations = True
    if args.rtol is not None:
        ti.newton.relativeTolerance = args.rtol
    if args.atol is not None:
        ti.newton.absoluteTolerance = args.atol
    ss.linearSolver.solverType = getattr(exu.LinearSolverType, args.linear_solver)
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = every * dt * (1 - 1e-9)
    ss.solution.sensors.writeHeader = True
    ss.solution.precision = 17          # as many digits as damper's CSV (shortest round trip)
    t0 = time.perf_counter()
    try:
        ok = mbs.SolveDynamic(ss, solverType=exu.DynamicSolverType.GeneralizedAlpha)
    except Exception as e:  # Exudyn raises its own exception types
        fail(f"Exudyn's solver failed: {str(e).splitlines()[0] if str(e) else type(e).__name__}")
    if ok is False:
        fail("Exudyn's solver did not finish")
    return time.perf_counter() - t0, steps, dt


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenario", nargs="?", default=os.path.join(REPO, "scenarios", "damper.toml"))
    ap.add_argument("-o", "--out", default="", help="directory for the sensor files (none: no files)")
    ap.add_argument("--dt", type=float, help="time step (default: the scenario's)")
    ap.add_argument("--t-end", type=float, help="end time (default: the scenario's)")
    ap.add_argument("--every", type=int, help="a sensor row every N steps (default: the scenario's)")
    ap.add_argument("--rho", type=float, help="generalized-alpha with this spectral radius "
                    "instead of Newmark's trapezoidal rule")
    ap.add_argument("--rtol", type=float, help="Newton's relative tolerance (Exudyn's default 1e-8)")
    ap.add_argument("--atol", type=float, help="Newton's absolute tolerance (Exudyn's default 1e-10)")
    ap.add_argument("--linear-solver", default="EigenSparse",
                    choices=["EXUdense", "EigenDense", "EigenSparse"],
                    help="Exudyn's linear solver (default EigenSparse: the fastest of the three here)")
    ap.add_argument("--csv", help="write t, tip w, w', q1, q2, q1', current to this CSV")
    ap.add_argument("--quiet", action="store_true", help="print nothing")
    args = ap.parse_args()
    args.internal = bool(args.csv)
    if not os.path.isfile(args.scenario):
        fail(f"{args.scenario}: no such scenario file")
    p = load_model(args.scenario)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
    sc, mbs, sensors, info = build(p, args)
    wall, steps, dt = simulate(mbs, p, args)
    if args.csv:
        w = mbs.GetSensorStoredData(sensors["tip_displacement"])
        v = mbs.GetSensorStoredData(sensors["tip_velocity"])
        c1 = mbs.GetSensorStoredData(sensors["crank"])
        r1 = mbs.GetSensorStoredData(sensors["crank_rate"])
        c2 = mbs.GetSensorStoredData(sensors["coupler"])
        rows = min(len(w), len(v), len(c1), len(r1), len(c2))
        ke_n_R = p["ke"] * p["n"] / p["R"]
        with open(args.csv, "w") as f:
            f.write("t [s],pin.w [m],pin.w_dot [m/s],damper.q1 [rad],damper.q2 [rad],"
                    "damper.q1_dot [rad/s],generator.current [A]\n")
            for k in range(rows):
                # Coordinates of a rigid-body node are displacements from the reference
                q1 = info["q1_0"] + c1[k, 3]
                q2 = info["q2_0"] + c2[k, 3] - c1[k, 3]
                f.write(f"{float(w[k,0])!r},{float(w[k,2])!r},{float(v[k,2])!r},{float(q1)!r},{float(q2)!r},{float(r1[k,3])!r},"
                        f"{float(ke_n_R * r1[k,3])!r}\n")
        e = mbs.GetSensorStoredData(sensors["coupler_end"])
        b = mbs.GetSensorStoredData(sensors["tip_position"])
        drift = float(np.max(np.hypot(e[:, 1] - b[:, 1], e[:, 2] - b[:, 2])))
        ux = float(np.max(np.abs(b[:, 1] - p["length"])))
        print(f"constraint drift: largest |coupler end - beam tip| {drift:.3g} m, "
              f"|tip ux| {ux:.3g} m", file=sys.stderr)
    if not args.quiet:
        print(f"exudyn {exu.__version__}: {steps} steps of {dt:g} s in {wall:.3f} s "
              f"(SolveDynamic), {info['ncoords']} ODE2 coordinates; beam f1, f2 = "
              f"{info['omega'][0]/2/math.pi:.4f}, {info['omega'][1]/2/math.pi:.4f} Hz, "
              f"Rayleigh a = {info['rayleigh'][0]:.6g} 1/s, b = {info['rayleigh'][1]:.6g} s; "
              f"c_g = {info['cg']:.6g} N m s, n^2 J_r = {info['n2Jr']:.3g} kg m^2")


if __name__ == "__main__":
    main()
