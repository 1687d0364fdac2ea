#!/usr/bin/env python3
"""Writes the model file of `mbs_symbolic::samples::spatial_chain(N)` (TOML, stdout), the
input of the generation-time measurement in README.md:

    python3 benches/peers/spatial_chain.py 32 > /tmp/spatial_chain_32.toml
    hyperfine 'target/release/damper generate /tmp/spatial_chain_32.toml -o /tmp/sc32.rs'

Revolute joints cycle through z, x, y; every fourth joint is prismatic along local x;
off-axis centres of mass, full inertia tensors, gravity -9.81 z; point `tip` at
(0.3, 0, 0) of the last body. Numbers are printed with repr (shortest round trip), so the
model is the same as the sample built in code.
"""
import math
import sys


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 32
    c, s = math.cos(0.3), math.sin(0.3)
    a, b = 0.02, 0.03
    ixx = c * c * a + s * s * b
    iyy = s * s * a + c * c * b
    ixy = c * s * (a - b)
    out = [f'name = "spatial_chain_{n}"', "gravity = [0.0, 0.0, -9.81]", ""]
    for i in range(n):
        joint = "T1" if i % 4 == 3 else ["R3", "R1", "R2"][i % 3]
        anchor = "[0.0, 0.0, 0.0]" if i == 0 else "[0.3, 0.05, 0.0]"
        parent = "ground" if i == 0 else f"b{i}"
        out += [
            "[[bodies]]",
            f'name = "b{i + 1}"',
            f'parent = "{parent}"',
            f'joint = "{joint}"',
            f"anchor = {anchor}",
            f'coordinate = "q{i + 1}"',
            f"mass = {1.0 + 0.1 * i!r}",
            "com = [0.15, 0.02, -0.01]",
            f"inertia = {{ xx = {ixx!r}, yy = {iyy!r}, zz = 0.04, xy = {ixy!r} }}",
            "",
        ]
    out += ["[[points]]", 'name = "tip"', f'body = "b{n}"', "position = [0.3, 0.0, 0.0]"]
    print("\n".join(out))


if __name__ == "__main__":
    main()
