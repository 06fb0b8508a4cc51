#!/usr/bin/env python3
"""Plots of the multiscale nanoindentation (examples-c/multiscale_indentation.c).

    plot_multiscale.py RESULTS_DIR [NAME [OTHER_NAME ...]]

Reads RESULTS_DIR/NAME.csv, NAME_profiles.csv, NAME_levels.csv and
NAME_deepest.csv (NAME defaults to "multiscale") and writes
RESULTS_DIR/NAME.png: the load against the depth (loading and unloading;
the load-depth curves of OTHER_NAME runs, e.g. the 4- and 6-level ones,
beside it), the energy balance over time, the contact pressure along the
wedge at several depths, and sigma_yy of the particles under the wedge at
the deepest point with the borders of the levels.
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402


def read(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    out = {}
    for k in rows[0] if rows else []:
        try:
            out[k] = [float(r[k]) for r in rows]
        except ValueError:
            out[k] = [r[k] for r in rows]
    return out


def branches(ts):
    depth = [v * 1e6 for v in ts["depth_m"]]
    load = [v / 1e3 for v in ts["load_n_per_m"]]
    k = max(range(len(depth)), key=lambda i: depth[i])
    return depth, load, k


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else "results"
    name = sys.argv[2] if len(sys.argv) > 2 else "multiscale"
    others = sys.argv[3:]
    ts = read(os.path.join(d, name + ".csv"))
    fig, ((a1, a2), (a3, a4)) = plt.subplots(2, 2, figsize=(12, 9.5))

    depth, load, k = branches(ts)
    a1.plot(depth[: k + 1], load[: k + 1], "-", color="C0", label=f"{name}: loading")
    a1.plot(depth[k:], load[k:], "-", color="C3", label=f"{name}: unloading")
    for j, other in enumerate(others):
        path = os.path.join(d, other + ".csv")
        if os.path.exists(path):
            od, ol, _ = branches(read(path))
            a1.plot(od, ol, "--", lw=0.9, color=f"C{j + 4}", label=other)
    a1.set_xlabel("depth of the tip below the undeformed surface (µm)")
    a1.set_ylabel("load on the full body (kN per metre of thickness)")
    a1.set_title("rigid 65° wedge on aluminium at up to 150 m/s")
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8)

    t = [v * 1e9 for v in ts["time_s"]]
    for key, label in [
        ("work_j_per_m", "work of the indenter"),
        ("kinetic_j_per_m", "kinetic"),
        ("strain_j_per_m", "strain"),
        ("dissipated_j_per_m", "work − kinetic − strain"),
    ]:
        a2.plot(t, ts[key], label=label)
    a2.set_xlabel("time (ns)")
    a2.set_ylabel("energy of the full body (J per metre of thickness)")
    a2.set_title("energy balance")
    a2.grid(alpha=0.3)
    a2.legend(fontsize=8)

    pp = os.path.join(d, name + "_profiles.csv")
    if os.path.exists(pp):
        pr = read(pp)
        if pr:
            keys = sorted(set(zip(pr["phase"], pr["depth_m"])), key=lambda q: (q[0] != "loading", q[1]))
            for j, (phase, dep) in enumerate(keys):
                sel = [i for i in range(len(pr["x_m"])) if pr["phase"][i] == phase and pr["depth_m"][i] == dep]
                xs = [pr["x_m"][i] * 1e6 for i in sel]
                ps = [pr["pressure_pa"][i] / 1e9 for i in sel]
                order = sorted(range(len(xs)), key=lambda i: xs[i])
                a3.plot([xs[i] for i in order], [ps[i] for i in order], "o-", ms=3, lw=0.8,
                        label=f"{phase} at {dep * 1e6:.2f} µm")
    a3.set_xlabel("x of the contact particle (µm)")
    a3.set_ylabel("contact pressure (GPa)")
    a3.set_title("contact pressure along the wedge")
    a3.grid(alpha=0.3)
    a3.legend(fontsize=8)

    wp = os.path.join(d, name + "_deepest.csv")
    if os.path.exists(wp):
        w = read(wp)
        x = [v * 1e6 for v in w["x_m"]]
        y = [v * 1e6 for v in w["y_m"]]
        s = [v / 1e9 for v in w["sigma_yy_pa"]]
        sc = a4.scatter(x, y, c=s, s=max(0.3, min(4.0, 3e4 / len(x))), cmap="viridis", vmin=max(min(s), -30), vmax=max(s), rasterized=True)
        fig.colorbar(sc, ax=a4, label="σyy (GPa)")
        lv = read(os.path.join(d, name + "_levels.csv"))
        x1, y0 = max(x), min(y)
        for i in range(1, len(lv["level"])):
            bx0, by0, bx1 = lv["x0_m"][i] * 1e6, lv["y0_m"][i] * 1e6, lv["x1_m"][i] * 1e6
            by1 = lv["y1_m"][i] * 1e6
            a4.add_patch(Rectangle((bx0, by0), bx1 - bx0, by1 - by0, fill=False, ec="r", lw=0.8))
            a4.text(min(bx1, x1) - 0.5, max(by0, y0) + 0.5, f"level {int(lv['level'][i])}", color="r",
                    ha="right", fontsize=7)
        a4.set_xlim(0, x1)
        a4.set_ylim(y0, max(y) + 0.5)
        a4.set_aspect("equal")
    a4.set_xlabel("x (µm)")
    a4.set_ylabel("y (µm)")
    a4.set_title("σyy at the deepest point, level borders in red")
    fig.tight_layout()
    out = os.path.join(d, name + ".png")
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
