"""The paper's damper: how the first mode's damping ratio zeta1 depends on the double bar's
half-angle (the closer to the toggle, the more amplification), from the linearised system."""

import sys

import damper

sc = damper.Scenario.load("scenarios/damper.toml")
sweep = sc.sweep({"mechanism.half_angle_deg": "3:25:23"})
angles = sweep["mechanism.half_angle_deg"]
zeta1 = sweep["linear.zeta1"]
best = int(zeta1.argmax())
print(f"highest zeta1 = {zeta1[best]:.4f} at a half-angle of {angles[best]} deg")

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no plot")
    sys.exit(0)

fig, ax = plt.subplots()
ax.plot(angles, zeta1 * 100, marker="o")
ax.set_xlabel("half-angle of the double bar [deg]")
ax.set_ylabel("first-mode damping ratio zeta1 [%]")
ax.set_title("The paper's damper: damping against the half-angle")
out = sys.argv[1] if len(sys.argv) > 1 else "zeta1_vs_half_angle.png"
fig.savefig(out)
print(f"plot: {out}")
