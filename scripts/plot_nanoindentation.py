#!/usr/bin/env python3
"""Plots of the wedge nanoindentation (examples-c/wedge_indentation.c).

    plot_nanoindentation.py RESULTS_DIR

Reads RESULTS_DIR/nanoindentation.csv and nanoindentation_tip.csv and
writes RESULTS_DIR/nanoindentation.png: the load on the full body per metre
of thickness against the depth, loading and unloading, and the contact
pressure along the wedge at the deepest point beside the closed form of a
rigid wedge on an elastic half-space, p(x) = (E* tan(b) / pi) arccosh(a/|x|)
(b = 90 deg - half-angle, a the contact half-width), for the load measured.
Prints how far the load at 450 nm is from the converged reference of the
work-precision study (docs/wedge_work_precision.json, written by `make
wedge-study`) when the run is the main job's scene, elastic, to 450 nm.
When RESULTS_DIR/nanoindentation_surface.csv exists (a run with unloading),
also writes RESULTS_DIR/nanoindentation_impression.png: the residual
impression, the vertical displacement of the top particle row against x
after the wedge has left, mirrored about the symmetry axis; an impression
deeper than 10 % of the largest depth marks an elastic-plastic run, for
which the elastic closed form of the pressure is not drawn.
"""
import csv
import json
import math
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}


def accuracy(ts, plastic):
    """The load at the deepest point against the study's converged reference."""
    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs",
                        "wedge_work_precision.json")
    k = max(range(len(ts["depth_m"])), key=lambda i: ts["depth_m"][i])
    depth, load = ts["depth_m"][k], ts["load_n_per_m"][k]
    if plastic or abs(depth - 4.5e-7) > 1e-10 or not os.path.exists(path):
        return
    with open(path) as f:
        st = json.load(f)
    ref = st["reference"]
    rows = ", ".join(f"{r['label']} {100 * r['error']:+.1f} % ({r['particles_across_a']:.1f} particles across a)"
                     for r in st["runs"] if re.fullmatch(r"levels_\d", r["name"]))
    print(f"load at 450 nm: {load:.1f} N/m, {100 * (load / ref['load'] - 1):+.2f} % from the converged reference "
          f"{ref['load']:.1f} N/m ({ref['how']}; `make wedge-study` of {st['date']}, commit {st['commit']}); "
          f"the work-precision table: {rows}")


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else "results"
    ts = read(os.path.join(d, "nanoindentation.csv"))
    tip_path = os.path.join(d, "nanoindentation_tip.csv")
    tip = read(tip_path) if os.path.exists(tip_path) else {}
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    depth = [v * 1e9 for v in ts["depth_m"]]
    load = ts["load_n_per_m"]
    k = max(range(len(depth)), key=lambda i: depth[i])
    a1.plot(depth[: k + 1], load[: k + 1], "-", color="C0", label="loading")
    a1.plot(depth[k:], load[k:], "-", color="C3", label="unloading")
    a1.set_xlabel("depth below the undeformed surface (nm)")
    a1.set_ylabel("load on the full body (N per metre of thickness)")
    a1.set_title("wedge (65 deg) on aluminium, plane strain")
    a1.grid(alpha=0.3)
    a1.legend()
    # An impression deeper than 10 % of the largest depth: an elastic-plastic
    # run, for which the elastic half-space pressure is no reference.
    surf_path = os.path.join(d, "nanoindentation_surface.csv")
    plastic = False
    if os.path.exists(surf_path):
        uy = read(surf_path).get("uy_m", [0.0])
        plastic = -min(uy) > 0.1 * max(ts["depth_m"])
    accuracy(ts, plastic)
    if tip:
        x = [v * 1e9 for v in tip["x_m"]]
        p = [v / 1e9 for v in tip["pressure_pa"]]
        a2.plot(x, p, "o", ms=3, label="GIMP contact particles")
        # Closed form for the measured load (half-space; finite block and
        # discrete contact differ near the tip and the edge).
        e_star = 70e9 / (1 - 0.33**2)
        tb = math.tan(math.radians(25.0))
        pmax_load = load[k]
        a = pmax_load / (e_star * tb)
        xs = [a * 1e9 * (i + 0.5) / 200 for i in range(200)]
        pc = [e_star * tb / math.pi * math.acosh(a * 1e9 / xx) / 1e9 for xx in xs]
        if not plastic:
            a2.plot(xs, pc, "-", color="k", lw=1, label="rigid wedge on a half-space")
        a2.set_xlabel("x (nm)")
        a2.set_ylabel("contact pressure (GPa)")
        a2.set_title("pressure at the deepest point")
        a2.grid(alpha=0.3)
        a2.legend()
    fig.tight_layout()
    out = os.path.join(d, "nanoindentation.png")
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")
    if os.path.exists(surf_path):
        sf = read(surf_path)
        x = [v * 1e6 for v in sf["x_m"]]
        uy = [v * 1e9 for v in sf["uy_m"]]
        fig, ax = plt.subplots(figsize=(8, 3.6))
        ax.plot([-v for v in x], uy, "-", color="C0", lw=1)
        ax.plot(x, uy, "-", color="C0", lw=1, label="top particle row after unloading")
        ax.axhline(0, color="k", lw=0.5)
        lim = min(max(x), 8.0)
        ax.set_xlim(-lim, lim)
        ax.set_xlabel("x (um)")
        ax.set_ylabel("vertical displacement (nm)")
        ax.set_title(f"residual impression: deepest {-min(uy):.1f} nm, pile-up {max(uy):.1f} nm")
        ax.grid(alpha=0.3)
        ax.legend()
        fig.tight_layout()
        out = os.path.join(d, "nanoindentation_impression.png")
        fig.savefig(out, dpi=120)
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
