#!/usr/bin/python3
"""Plots of the indentation demo: the stresses on the symmetry axis beside
the closed-form strip load on a half-space, and the energy history.

    plot_indentation.py RESULTS_DIR

Reads RESULTS_DIR/axis_stress.csv and RESULTS_DIR/indentation.csv, writes
RESULTS_DIR/axis_stress.png and RESULTS_DIR/energy.png."""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "results"
    ax_data = read(os.path.join(out, "axis_stress.csv"))
    order = sorted(range(len(ax_data["depth_m"])), key=lambda i: ax_data["depth_m"][i])
    z = [ax_data["depth_m"][i] * 1e6 for i in order]
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for key, hs, label, mark in [
        ("sigma_z_gimp_pa", "sigma_z_halfspace_pa", r"$\sigma_z$", "o"),
        ("sigma_x_gimp_pa", "sigma_x_halfspace_pa", r"$\sigma_x$", "s"),
    ]:
        ax.plot(z, [ax_data[key][i] / 1e9 for i in order], mark, ms=3, label=label + " GIMP")
        ax.plot(z, [ax_data[hs][i] / 1e9 for i in order], "-", label=label + " half-space")
    ax.set_xlabel("depth below the loaded surface on the axis (um)")
    ax.set_ylabel("compressive stress (GPa)")
    ax.set_title("Silicon under a 2 GPa strip pressure (half model)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, "axis_stress.png"), dpi=120)

    ts = read(os.path.join(out, "indentation.csv"))
    fig, ax = plt.subplots(figsize=(6, 4.2))
    t = [v * 1e9 for v in ts["time"]]
    ax.plot(t, [v * 1e6 for v in ts["kinetic_energy"]], label="kinetic")
    ax.plot(t, [v * 1e6 for v in ts["strain_energy"]], label="strain")
    ax.set_xlabel("time (ns)")
    ax.set_ylabel("energy per unit thickness (uJ/m)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, "energy.png"), dpi=120)
    print(f"wrote {out}/axis_stress.png and {out}/energy.png")


if __name__ == "__main__":
    main()
