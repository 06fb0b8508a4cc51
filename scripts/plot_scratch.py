#!/usr/bin/env python3
"""Plots of the scratch test (examples-c/scratch.c).

    plot_scratch.py RESULTS_DIR [NAME ...]

Reads RESULTS_DIR/NAME.csv (the force series), NAME_groove.csv (the
surface after lift-off: the particles' upper envelope) and NAME.json (the run's settings and
summary) for each NAME (default: scratch) and writes RESULTS_DIR/NAME.png
for the first NAME, three panels:

- the forces on the wedge against its lateral travel: the tangential
  force -Fx (the resistance to the +x motion) and the normal load Fy,
  per metre of thickness (the axis stops at 2.5 times the median load;
  the single-step spikes above are counted in the title);
- the friction ratio -Fx/Fy against the travel, with the friction
  coefficient mu, the ratio of a front flank in Coulomb slip alone,
  (tan b + mu)/(1 - mu tan b) (b = 90 deg - the half-angle: 25 deg), and
  the window of gross sliding with the ratio's median there;
- the groove: the height of the surface above the original one against
  x after the wedge has left, with the track (start and end of the tip's
  travel) and the scratch depth marked.

Further NAMEs (e.g. a frictionless run, `scratch --friction 0 --name
scratch_mu0`) are drawn in the same panels for comparison.
"""
import csv
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else "results"
    names = sys.argv[2:] or ["scratch"]
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(9, 10))
    top = 0.0
    for k, name in enumerate(names):
        ts = read(os.path.join(d, name + ".csv"))
        gr = read(os.path.join(d, name + "_groove.csv"))
        with open(os.path.join(d, name + ".json")) as f:
            js = json.load(f)
        mu = js["mu"]
        lab = f"μ = {mu}" if len(names) > 1 else ""
        x0, travel, depth = js["x_start_m"], js["travel_m"], js["depth_m"]
        # The sliding phase: from the first lateral movement to the end of the
        # travel, while the wedge is at its depth.
        sl = [i for i, (x, dd) in enumerate(zip(ts["x_tip_m"], ts["depth_m"]))
              if x > 0 and dd > 0.99 * depth and ts["x_tip_m"][i] <= travel]
        x = [ts["x_tip_m"][i] * 1e6 for i in sl]
        fx = [-ts["fx_n_per_m"][i] for i in sl]
        fy = [ts["fy_n_per_m"][i] for i in sl]
        c = f"C{2 * k}"
        a1.plot(x, fy, "-", color=c, lw=1, label=f"normal load Fy {lab}")
        med = sorted(fy)[len(fy) // 2] if fy else 0.0
        top = max(top, 2.5 * med)
        spikes = sum(1 for v in fy if v > 2.5 * med)
        a1.plot(x, fx, "--", color=f"C{2 * k + 1}", lw=1, label=f"tangential force −Fx {lab}")
        ratio = [a / b if b > 0 else float("nan") for a, b in zip(fx, fy)]
        a2.plot(x, ratio, "-", color=c, lw=1, label=f"−Fx/Fy {lab}")
        if mu != "inf":
            tb = math.tan(math.radians(25.0))
            m = float(mu)
            a2.axhline(m, color=c, ls=":", lw=1, label=f"μ = {mu}" + (" (friction coefficient)" if k == 0 else ""))
            front = (tb + m) / (1 - m * tb)
            a2.axhline(front, color=c, ls="--", lw=0.8,
                       label=f"front flank sliding, (tan 25° + μ)/(1 − μ tan 25°) = {front:.3f}")
        lo, hi = js["window_m"]
        if k == 0:
            a2.axvspan(lo * 1e6, hi * 1e6, color="0.9", label="gross sliding (averaged)")
        a2.plot([lo * 1e6, hi * 1e6], [js["ratio_median"]] * 2, "-", color=c, lw=2.5, alpha=0.6,
                label=f"median −Fx/Fy {js['ratio_median']:.3f} (ratio of the mean forces {js['ratio']:.3f}) {lab}")
        gx = [v * 1e6 for v in gr["x_m"]]
        gy = [v * 1e9 for v in gr["height_m"]]
        a3.plot(gx, gy, "-", color=c, lw=1, label=f"surface after lift-off {lab}")
        if k == 0:
            for xm, t in ((x0, "start"), (x0 + travel, "end")):
                a3.axvline(xm * 1e6, color="k", lw=0.6, ls="--")
                a3.annotate(t, (xm * 1e6, 0), textcoords="offset points", xytext=(3, -12), fontsize=8)
            a3.axhline(-depth * 1e9, color="0.5", lw=0.6, ls=":", label="scratch depth")
            title = (f"scratch: 65° wedge, {js['material'].upper() if js['material'] == 'j2' else 'elastic'} "
                     f"aluminium, {depth * 1e9:.0f} nm deep, {travel * 1e6:g} µm at "
                     f"{js['lateral_speed_m_per_s']:g} m/s, μ = {mu} ({js['wall_s']:.0f} s on {js['ranks']} ranks)")
            a1.set_title(title + f"\n{spikes} single-step load spikes above {2.5 * med:.0f} N/m (largest "
                         f"{max(fy):.0f} N/m) not shown", fontsize=10)
    a1.set_xlabel("lateral travel of the tip (µm)")
    a1.set_ylabel("force on the wedge (N/m)")
    if top > 0:
        a1.set_ylim(0, top)
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8)
    a2.set_xlabel("lateral travel of the tip (µm)")
    a2.set_ylabel("friction ratio −Fx/Fy")
    a2.grid(alpha=0.3)
    a2.legend(fontsize=8)
    a3.set_xlabel("x (µm)")
    a3.set_ylabel("height above the original surface (nm)")
    a3.set_title("groove and prow", fontsize=10)
    a3.grid(alpha=0.3)
    a3.legend(fontsize=8)
    lo = min(js["x_start_m"] for js in [json.load(open(os.path.join(d, n + ".json"))) for n in names])
    a3.set_xlim(lo * 1e6 - 5, (lo + travel) * 1e6 + 5)
    fig.tight_layout()
    out = os.path.join(d, names[0] + ".png")
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
