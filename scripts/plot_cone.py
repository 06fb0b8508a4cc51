#!/usr/bin/env python3
"""Plots of the axisymmetric cone nanoindentation (examples-c/cone_indentation.c).

    plot_cone.py RESULTS_DIR [NAME]

Reads RESULTS_DIR/NAME.csv (the load-depth series), NAME_surface.csv (the
top particle row at the start of unloading and after the cone has left),
NAME_field.csv (the particles near the tip at the start of unloading) and
NAME.json (the run's summary) (NAME: cone by default), and writes
RESULTS_DIR/NAME.png with three panels:

- the load on the whole body against the depth, loading and unloading,
  with the least-squares P = C h^2 of the loading curve's second half and,
  for an elastic run, Sneddon's cone (2/pi) E* tan(psi) h^2;
- the surface: the residual impression (the rise of the top particle row's
  centres above the original surface, mirrored about the axis) with its
  pile-up, the surface under load and the cone at the largest depth, the
  true contact radius marked;
- the hoop stress sigma_tt at the start of unloading: each particle drawn
  as its domain (r +- lr, z +- lz) near the tip.

The particle data come from the CSV files, not from the HDF5 series (h5py
is not needed); NAME.xdmf has every field for ParaView.
"""
import csv
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PatchCollection  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402


def read(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else "results"
    name = sys.argv[2] if len(sys.argv) > 2 else "cone"
    ts = read(os.path.join(d, name + ".csv"))
    sf = read(os.path.join(d, name + "_surface.csv"))
    fd = read(os.path.join(d, name + "_field.csv"))
    with open(os.path.join(d, name + ".json")) as f:
        js = json.load(f)
    psi = math.radians(js["half_angle_deg"])
    z_top, h_max = js["surface_z_m"], js["depth_m"]
    a = js.get("true_contact_radius_m") or h_max * math.tan(psi)
    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(17, 5.2))

    # Load-depth.
    h = [v * 1e9 for v in ts["depth_m"]]
    p = [v * 1e3 for v in ts["load_n"]]
    k = max(range(len(h)), key=lambda i: (h[i], i))  # the start of unloading
    a1.plot(h[: k + 1], p[: k + 1], "-", color="C0", label="loading and hold")
    a1.plot(h[k:], p[k:], "-", color="C3", label="unloading")
    hs = [h_max * 1e9 * i / 100 for i in range(101)]
    if js.get("c_fit_pa"):
        c = js["c_fit_pa"]
        a1.plot(hs, [c * (x * 1e-9) ** 2 * 1e3 for x in hs], ":", color="k", lw=1,
                label=f"P = C h², C = {c / 1e9:.3g} GPa (fit)")
    if js["material"] == "elastic":
        cs = 2 / math.pi * js["input_reduced_modulus_pa"] * math.tan(psi)
        a1.plot(hs, [cs * (x * 1e-9) ** 2 * 1e3 for x in hs], "--", color="C2", lw=1,
                label="Sneddon (2/π) E* tan ψ h²")
    a1.set_xlabel("depth below the undeformed surface (nm)")
    a1.set_ylabel("load on the whole body (mN)")
    title = f"{js['half_angle_deg']:g}° cone, {js['material']} aluminium"
    if js.get("hardness_pa") and js.get("reduced_modulus_pa"):
        title += (f"\nH = {js['hardness_pa'] / 1e9:.3g} GPa (true area {js['true_hardness_pa'] / 1e9:.3g}), "
                  f"E_r = {js['reduced_modulus_pa'] / 1e9:.3g} GPa (input {js['input_reduced_modulus_pa'] / 1e9:.3g})")
    a1.set_title(title, fontsize=10)
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8, loc="upper left")

    # The surface.
    r_res = [v * 1e6 for v in sf["r_res_m"]]
    uz_res = [v * 1e9 for v in sf["uz_res_m"]]
    r_ld = [v * 1e6 for v in sf["r_load_m"]]
    uz_ld = [v * 1e9 for v in sf["uz_load_m"]]
    lim = 3 * a * 1e6
    for sgn in (1, -1):
        a2.plot([sgn * v for v in r_res], uz_res, "-", color="C0", lw=1.5,
                label="after unloading" if sgn > 0 else None)
        a2.plot([sgn * v for v in r_ld], uz_ld, "--", color="C1", lw=1, label="at the start of unloading" if sgn > 0 else None)
    rc = [lim * (i - 100) / 100 for i in range(201)]
    a2.plot(rc, [-h_max * 1e9 + abs(x) * 1e3 / math.tan(psi) for x in rc], "-", color="0.5", lw=0.8,
            label="cone at the largest depth")
    a2.axhline(0, color="k", lw=0.5)
    a2.axvline(a * 1e6, color="C3", lw=0.6, ls=":", label=f"true contact radius {a * 1e9:.0f} nm")
    a2.axvline(-a * 1e6, color="C3", lw=0.6, ls=":")
    a2.set_xlim(-lim, lim)
    a2.set_ylim(-1.15 * h_max * 1e9, max(0.3 * h_max * 1e9, 1.5 * max(uz_res + [0])))
    a2.set_xlabel("r (µm)")
    a2.set_ylabel("height of the surface (nm)")
    pile = js.get("pileup_m") or 0.0
    a2.set_title(f"residual impression: {js['impression_depth_m'] * 1e9:.1f} nm deep, pile-up {pile * 1e9:+.1f} nm"
                 + (f"\ntrue / Oliver-Pharr area {js['area_ratio']:.3f}" if js.get("area_ratio") else ""),
                 fontsize=10)
    a2.grid(alpha=0.3)
    a2.legend(fontsize=8, loc="lower right")

    # The hoop stress at the start of unloading.
    win = 3 * a
    sel = [i for i in range(len(fd["r_m"])) if fd["r_m"][i] - fd["lr_m"][i] < win and fd["z_m"][i] > z_top - win]
    rects = [Rectangle(((fd["r_m"][i] - fd["lr_m"][i]) * 1e6, (fd["z_m"][i] - fd["lz_m"][i] - z_top) * 1e6),
                       2 * fd["lr_m"][i] * 1e6, 2 * fd["lz_m"][i] * 1e6) for i in sel]
    st = [fd["s_tt_pa"][i] / 1e9 for i in sel]
    lim_s = sorted(abs(v) for v in st)[int(0.99 * (len(st) - 1))] if st else 1.0
    pc = PatchCollection(rects, cmap="RdBu_r", edgecolor="none")
    pc.set_array(st)
    pc.set_clim(-lim_s, lim_s)
    a3.add_collection(pc)
    rr = [win * 1e6 * i / 100 for i in range(101)]
    a3.plot(rr, [(-h_max + x * 1e-6 / math.tan(psi)) * 1e6 for x in rr], "-", color="k", lw=0.8)
    a3.set_xlim(0, win * 1e6)
    a3.set_ylim(-win * 1e6, 0.25 * win * 1e6)
    a3.set_aspect("equal")
    a3.set_xlabel("r (µm)")
    a3.set_ylabel("z below the original surface (µm)")
    a3.set_title("hoop stress σ_θθ at the start of unloading", fontsize=10)
    fig.colorbar(pc, ax=a3, label="σ_θθ (GPa)", shrink=0.85)
    fig.tight_layout()
    out = os.path.join(d, name + ".png")
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
