#!/usr/bin/env python3
"""Work-precision plot of Gimlet's manufactured-solution study.

Usage: python3 scripts/plot_work_precision.py [CSV] [PNG]
  CSV  written by `cargo run --release -p gimlet-validate --bin gimlet-validate -- --work-precision`
       (default results/work_precision.csv)
  PNG  output (default: the CSV path with .png)

One panel per amplitude: error (RMS displacement, max over time) against the
wall time of the solver's steps, log-log, one line per method, each point
labelled with its cells per side. Needs matplotlib (Debian: python3-matplotlib).
"""

import csv
import math
import os
import sys


def load_matplotlib():
    try:
        import matplotlib
    except ImportError:
        # A python3 from pyenv/venv first in PATH may not see Debian's
        # python3-matplotlib: retry once with the system interpreter.
        system = "/usr/bin/python3"
        if os.path.exists(system) and os.path.realpath(sys.executable) != os.path.realpath(system) \
                and not os.environ.get("GIMLET_PLOT_REEXEC"):
            os.environ["GIMLET_PLOT_REEXEC"] = "1"
            os.execv(system, [system] + sys.argv)
        sys.exit("plot_work_precision.py: matplotlib is missing "
                 "(apt-get install -y python3-matplotlib)")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def read_rows(path):
    rows = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            err = float(r["error"])
            sec = float(r["seconds"])
            if not (math.isfinite(err) and err > 0 and sec > 0):
                continue
            rows.append({
                "amplitude": float(r["amplitude"]),
                "method": r["method"],
                "cells": int(r["cells"]),
                "error": err,
                "seconds": sec,
                "rate": float(r["particle_steps_per_s"]),
            })
    return rows


STYLE = {
    "Mpm": ("MPM", "tab:red", "s"),
    "UGimp": ("uGIMP", "tab:blue", "o"),
    "CpGimp": ("cpGIMP", "tab:green", "^"),
}


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else "results/work_precision.csv"
    dst = sys.argv[2] if len(sys.argv) > 2 else os.path.splitext(src)[0] + ".png"
    rows = read_rows(src)
    if not rows:
        sys.exit(f"plot_work_precision.py: no usable rows in {src}")
    plt = load_matplotlib()
    amps = sorted({r["amplitude"] for r in rows})
    fig, axes = plt.subplots(1, len(amps), figsize=(6.2 * len(amps), 5.0), squeeze=False)
    for ax, amp in zip(axes[0], amps):
        for key, (label, color, marker) in STYLE.items():
            pts = sorted((r for r in rows if r["amplitude"] == amp and r["method"] == key),
                         key=lambda r: r["cells"])
            if not pts:
                continue
            xs = [r["seconds"] for r in pts]
            ys = [r["error"] for r in pts]
            fine = pts[-1]
            ax.loglog(xs, ys, marker=marker, color=color, lw=1.6, ms=7,
                      label=f"{label} ({fine['rate'] / 1e6:.1f} M particle-steps/s "
                            f"at {fine['cells']} cells)")
            for r in pts:
                ax.annotate(str(r["cells"]), (r["seconds"], r["error"]),
                            textcoords="offset points", xytext=(5, 4), fontsize=8, color=color)
        # reference slope: error ~ time^(-2/3) is second order in h (time ~ h^-3 in 2D
        # at fixed CFL and particles per cell)
        gimp = sorted((r for r in rows if r["amplitude"] == amp and r["method"] == "CpGimp"),
                      key=lambda r: r["seconds"])
        if len(gimp) >= 2:
            x0, y0 = gimp[0]["seconds"], gimp[0]["error"]
            x1 = gimp[-1]["seconds"]
            ax.loglog([x0, x1], [y0 * 1.8, y0 * 1.8 * (x1 / x0) ** (-2.0 / 3.0)], "k--", lw=0.9,
                      label=r"2nd order in $h$ (error $\propto$ time$^{-2/3}$)")
        ax.set_title(f"manufactured solution, A = {amp:g} (labels: cells per side)")
        ax.set_xlabel("wall time of the solver steps (s, one core)")
        ax.set_ylabel("RMS displacement error, max over time (m)")
        ax.grid(True, which="both", ls=":", lw=0.5)
        ax.legend(fontsize=8, loc="best")
    fig.suptitle("Gimlet work-precision: plain MPM vs uGIMP vs cpGIMP (MUSL, 2x2 particles/cell, "
                 "dt = 0.2 h/c)", fontsize=10)
    fig.tight_layout()
    fig.savefig(dst, dpi=130)
    print(f"wrote {dst}")


if __name__ == "__main__":
    main()
