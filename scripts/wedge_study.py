#!/usr/bin/env python3
"""Work-precision study of the main job (issue 27): the paper's 65 deg wedge
pushed 450 nm into the elastic aluminium block at 10 m/s
(examples-c/wedge_indentation.c, loading only), on 2 ranks:

- 3, 4 and 5 nested levels (coarse cells 500 nm, finest 125, 62.5 and
  31.25 nm; each level's box half the next coarser one's): what a user gets
  for the time spent;
- 3 levels with every cell halved and quartered (the same three boxes): a
  refinement sequence of the whole discretisation, from which the converged
  reference is extrapolated (Richardson, with the order observed from the
  three runs);
- checks: one uniform level of 125 nm cells (levels against their uniform
  finest twin), the main job at half the speed (quasi-static) and with a
  shorter step.

Every run's load at 450 nm and whole loading curve (100-450 nm, pointwise
extrapolated reference) are compared with the reference; the contact
half-width and the pressure profile with the closed form of a rigid wedge
on an elastic half-space. About 30 minutes on 2 cores.

  scripts/wedge_study.py [--np N] [--out DIR] [--build DIR] [--no-docs] [--reuse]

Writes DIR/wedge_work_precision.csv (one row per run), DIR/wedge_work_precision.json
(the runs, the reference and the checks), DIR/wedge_work_precision.png (error
against wall time, log-log) and the runs' outputs under DIR/wedge_study/, and,
unless --no-docs, the generated table of README.md (between its wedge-study
markers) and docs/wedge_work_precision.json, which `make demo` reads to say
how far its resolution is from converged.
"""
import argparse
import csv
import datetime
import json
import math
import os
import re
import sys

import logged_run

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BEGIN = "<!-- wedge-study:begin"
END = "<!-- wedge-study:end -->"
E, NU, HALF_ANGLE = 70e9, 0.33, 65.0
E_STAR = E / (1 - NU * NU)
COT_PSI = math.tan(math.radians(90 - HALF_ANGLE))  # the flank's slope
DEPTH = 4.5e-7
CURVE = [k * 1e-8 for k in range(10, 45)] + [4.4999e-7]  # 100-450 nm


def run(exe, np_, name, args, out, reuse=False):
    d = os.path.join(out, "wedge_study", name)
    os.makedirs(d, exist_ok=True)
    cmd = ["mpiexec", "-n", str(np_), exe, "--petsc", "--unload", "0", "--quiet", "--out", d] + args
    stdout = logged_run.run_logged(cmd, d, name, reuse, "wedge_study")
    js = next(json.loads(line) for line in stdout.splitlines() if line.startswith('{"case":"wedge"'))
    m = re.search(r"finest cell ([0-9.e+-]+) nm", stdout)
    r = {
        "name": name,
        "args": " ".join(args),
        "ranks": np_,
        "levels": js["levels"],
        "finest_cell_nm": float(m.group(1)),
        "particles": js["particles"],
        "steps": js["steps"],
        "wall_s": js["wall_s"],
        "load": js["load_at_depth_n_per_m"],
        "a_m": js["contact_half_width_m"],
    }
    r["particles_across_a"] = r["a_m"] / (0.5 * r["finest_cell_nm"] * 1e-9)
    r["curve"] = curve(os.path.join(d, "nanoindentation.csv"))
    r["profile"] = profile(os.path.join(d, "nanoindentation_tip.csv"), r["a_m"], 0.5 * r["finest_cell_nm"] * 1e-9)
    print(f"  {name:18s} {r['args']:24s} finest {r['finest_cell_nm']:7.3f} nm  load {r['load']:9.2f} N/m  "
          f"a {r['a_m'] * 1e9:6.1f} nm ({r['particles_across_a']:5.2f} particles)  {r['wall_s']:7.1f} s",
          flush=True)
    return r


def curve(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    c = [(float(r["depth_m"]), float(r["load_n_per_m"])) for r in rows]
    return [at(c, d) for d in CURVE]


def at(c, d):
    for (d0, p0), (d1, p1) in zip(c, c[1:]):
        if d1 >= d:
            return p0 + (d - d0) / (d1 - d0) * (p1 - p0) if d1 > d0 else p1
    return c[-1][1]


def closed_form_pressure(x, a):
    """The rigid wedge on an elastic half-space: p = (E* cot psi / pi) arccosh(a/|x|)."""
    return E_STAR * COT_PSI / math.pi * math.acosh(a / abs(x)) if abs(x) < a else 0.0


def profile(path, a, d):
    """RMS of the contact pressure's difference from the closed form (with the
    run's own a) over 0.1a < x < 0.9a, relative to the mean pressure
    E* cot psi / 2, and the number of particles in that range.

    The library reports a particle's pressure per its contact-face length
    l = 2 lx |ny| + 2 ly |nx|; a particle of size d (uGIMP, undeformed) in
    the staircase under a flank covers d / |ny| of it (1.20 times less at
    the 65 deg wedge), d on the apex (an axis normal, l = d). The profile
    compares the force per length of flank covered, p l / covered."""
    ny = math.sin(math.radians(HALF_ANGLE))
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if float(r["pressure_pa"]) > 0]
    pts = []
    for r in rows:
        x, p, ln = float(r["x_m"]), float(r["pressure_pa"]), float(r["face_length_m"])
        covered = d if ln < 1.01 * d else d / ny
        pts.append((x, p * ln / covered))
    inside = [(x, p) for x, p in pts if 0.1 * a < abs(x) < 0.9 * a]
    if not inside:
        return {"rms": float("nan"), "points": 0}
    pm = 0.5 * E_STAR * COT_PSI
    e = [(p - closed_form_pressure(x, a)) / pm for x, p in inside]
    return {"rms": (sum(v * v for v in e) / len(e)) ** 0.5, "points": len(e)}


def richardson(c, m, f):
    """Order and extrapolated value from three values on cells h, h/2, h/4."""
    d1, d2 = m - c, f - m
    if d1 == 0 or d2 == 0 or d1 / d2 <= 1:
        return float("nan"), float("nan")
    p = math.log2(d1 / d2)
    return p, f + d2 / (2**p - 1)


def write_docs(study, readme):
    rows = study["runs"]
    ref = study["reference"]
    out = [
        f"{BEGIN} (generated by scripts/wedge_study.py, `make wedge-study`; do not edit) -->",
        f"Generated by `make wedge-study` ({study['date']}, commit {study['commit']}, {study['ranks']} ranks). "
        f"The 65° wedge pushed 450 nm into the paper's elastic block at 10 m/s (the main job's loading); "
        f"reference: {ref['how']}, **{ref['load']:.1f} N/m**.",
        "",
        "| run | finest cell | particles across a | load at 450 nm | error | curve 100–450 nm: largest / RMS "
        "| pressure vs closed form (RMS) | wall (2 ranks) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r["name"].startswith("nearest_"):
            continue  # reference-building runs: their loads are in the checks
        out.append(
            f"| {r['label']} | {r['finest_cell_nm']:g} nm | {r['particles_across_a']:.1f} | {r['load']:.1f} N/m "
            f"| **{100 * r['error']:+.2f} %** | {100 * r['curve_max']:.2f} % / {100 * r['curve_rms']:.2f} % "
            f"| {100 * r['profile']['rms']:.1f} % ({r['profile']['points']} pts) | {r['wall_s']:.0f} s |")
    out.append("")
    for c in study["checks"]:
        out.append(f"- {c}")
    out.append(END)
    text = open(readme).read()
    i, j = text.find(BEGIN), text.find(END)
    if i < 0 or j < 0:
        sys.exit(f"wedge_study: {readme} has no {BEGIN} ... {END} markers")
    with open(readme, "w") as f:
        f.write(text[:i] + "\n".join(out) + text[j + len(END):])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--np", type=int, default=2)
    ap.add_argument("--out", default="results")
    ap.add_argument("--build", default=os.environ.get("BUILD", "build"))
    ap.add_argument("--no-docs", action="store_true")
    ap.add_argument("--reuse", action="store_true",
                    help="reuse a run whose output directory holds the same command's complete log (same build)")
    o = ap.parse_args()
    exe = os.path.join(o.build, "examples-c", "wedge_indentation")
    print(f"wedge work-precision study on {o.np} rank(s): 65 deg wedge to 450 nm, elastic aluminium", flush=True)
    runs = []

    def add(name, label, args):
        r = run(exe, o.np, name, args, o.out, o.reuse)
        r["label"] = label
        runs.append(r)
        return r

    lv = [add("levels_3", "3 levels (the main job)", ["--levels", "3"]),
          add("levels_4", "4 levels", ["--levels", "4"]),
          add("levels_5", "5 levels", ["--levels", "5"])]
    # 6 levels (15.6 nm cells in a 0.625 um box, 2.7 contact half-widths):
    # the compression under the tip shortens the stable step to 0.65 of
    # the initial one, and the level boundaries' own error (see the checks)
    # grows as the boxes close in on the contact: left out.
    # Every cell halved, the same three level boxes: the reference.
    hs = [lv[0],
          add("coarse_250nm", "3 levels, cells halved (250/125/62.5 nm)", ["--levels", "3", "--h0", "2.5e-7"]),
          add("coarse_125nm", "3 levels, cells quartered (125/62.5/31.25 nm)", ["--levels", "3", "--h0", "1.25e-7"])]
    # The same with the contact gap at the domain's nearest point (the
    # other GIMLET_CONTACT_GAP): a second sequence to the same limit.
    ns = [add("nearest_levels_3", "3 levels, nearest-point gap", ["--levels", "3", "--contact-gap", "0"]),
          add("nearest_coarse_250nm", "the same, cells halved", ["--levels", "3", "--h0", "2.5e-7",
                                                                  "--contact-gap", "0"]),
          add("nearest_coarse_125nm", "the same, cells quartered", ["--levels", "3", "--h0", "1.25e-7",
                                                                     "--contact-gap", "0"])]
    uni = add("uniform_125nm", "uniform 125 nm cells", ["--uniform", "1.25e-7"])
    # Fewer particles across a: where the 1, 2 and 5 % bounds are crossed.
    few = [add("coarse_1um", "3 levels, cells doubled (1000/500/250 nm)", ["--levels", "3", "--h0", "1e-6"]),
           add("levels_2_1um", "2 levels (1000/500 nm)", ["--levels", "2", "--h0", "1e-6"]),
           add("uniform_1um", "uniform 1 um cells", ["--uniform", "1e-6"])]
    slow = add("levels_3_5ms", "3 levels at 5 m/s", ["--levels", "3", "--speed", "5"])
    step = add("levels_3_dt07", "3 levels, step 0.7 of the stable one", ["--levels", "3", "--dt-factor", "0.7"])
    # The reference. The default gap's sequence first: Richardson when it
    # is monotone with an order above 1/2; when it is not (it has
    # converged to within its last change), its finest run, with the last
    # change as its uncertainty. The nearest-point sequence, whose leading
    # error (the staircase's push-in, lx |nx|) is of first order, checks it:
    # extrapolated with order 1 and with its observed order.
    p_d, ref_d = richardson(*(r["load"] for r in hs))
    p_n, ref_n = richardson(*(r["load"] for r in ns))
    ref_n1 = ns[2]["load"] + (ns[2]["load"] - ns[1]["load"])
    seq = hs
    if math.isfinite(ref_d) and p_d > 0.5:
        p, ref = p_d, ref_d
        how = (f"Richardson extrapolation of the 3-level runs with every cell halved twice (finest 125, 62.5, "
               f"31.25 nm), observed order {p:.2f}")
        extrapolate = True
    else:
        p, ref = float("nan"), hs[2]["load"]
        how = (f"the 3-level run with every cell quartered (finest 31.25 nm, 15 particles across a): the "
               f"sequence with cells halved twice changes by {100 * (hs[1]['load'] / hs[0]['load'] - 1):+.2f} % "
               f"then {100 * (hs[2]['load'] / hs[1]['load'] - 1):+.3f} %, converged to about "
               f"{100 * abs(hs[2]['load'] / hs[1]['load'] - 1):.2f} % (no order: not monotone)")
        extrapolate = False
    # The whole curve: pointwise with the order of the load at 450 nm.
    ref_curve = ([f + (f - m) / (2**p - 1) for m, f in zip(seq[1]["curve"], seq[2]["curve"])] if extrapolate
                 else list(seq[2]["curve"]))
    orders = {}
    for k, d in enumerate(CURVE):
        if round(d * 1e9) in (200, 300, 400):
            orders[f"{round(d * 1e9)} nm"] = richardson(*(r["curve"][k] for r in seq))[0]
    for r in runs:
        r["error"] = r["load"] / ref - 1
        e = [c / rc - 1 for c, rc in zip(r["curve"], ref_curve)]
        r["curve_max"] = max(abs(v) for v in e)
        r["curve_rms"] = (sum(v * v for v in e) / len(e)) ** 0.5
    a_ref = ref / (E_STAR * COT_PSI)
    print(f"reference: {how}: load at 450 nm {ref:.2f} N/m; orders at 200/300/400 nm: "
          f"{', '.join(f'{v:.2f}' for v in orders.values())}")
    print(f"  its contact half-width by the half-space closed form P = a E* cot(psi): {a_ref * 1e9:.1f} nm")
    print(f"{'run':48s} {'finest':>9s} {'across a':>9s} {'load':>10s} {'error':>8s} {'curve max/RMS':>15s} "
          f"{'profile':>8s} {'wall':>7s}")
    for r in runs:
        print(f"{r['label']:48s} {r['finest_cell_nm']:7.3f}nm {r['particles_across_a']:9.2f} {r['load']:10.2f} "
              f"{100 * r['error']:+7.2f}% {100 * r['curve_max']:6.2f}/{100 * r['curve_rms']:5.2f} % "
              f"{100 * r['profile']['rms']:7.1f}% {r['wall_s']:6.1f}s")
    l3, l4 = lv[0], lv[1]
    errs = ", ".join(f"{100 * (r['load'] / ref - 1):+.2f} %" for r in ns)
    d4 = 100 * (l4['load'] / hs[1]['load'] - 1)
    d5 = 100 * (lv[2]['load'] / hs[2]['load'] - 1)
    checks = [
        f"The contact gap at the domain's nearest point (GIMLET_CONTACT_GAP 0), same three runs: "
        f"{', '.join('%.1f' % r['load'] for r in ns)} N/m, {errs} from the reference, falling towards first "
        f"order as the staircase's push-in (lx |nx|) predicts; extrapolated with order 1: {ref_n1:.1f} N/m "
        f"({100 * (ref_n1 / ref - 1):+.2f} %), with its observed order {p_n:.2f}: {ref_n:.1f} N/m "
        f"({100 * (ref_n / ref - 1):+.2f} %).",
        f"Added levels against halved cells: at the same "
        f"finest cell, 4 levels are {d4:+.2f} % and 5 levels {d5:+.2f} % from 3 levels with halved cells: "
        + ("the added level boundaries, nearer the tip, cost no more than the halved cells' own change; the "
           "reference still comes from halved cells, the refinement of the whole discretisation."
           if max(abs(d4), abs(d5)) <= 100 * abs(hs[1]['load'] / hs[0]['load'] - 1) + 0.05 else
           "each added level boundary, nearer the tip, adds an error of its own (not the cell size's), so the "
           "level runs are no refinement sequence and the reference comes from halved cells."),
        f"Levels against their uniform finest twin: 3 levels {100 * (l3['load'] / uni['load'] - 1):+.2f} % from one "
        f"level of 125 nm cells at 450 nm, in {l3['wall_s'] / uni['wall_s']:.0%} of its wall time.",
        f"Quasi-static: at 5 m/s the 3-level load is {100 * (slow['load'] / l3['load'] - 1):+.2f} % from 10 m/s "
        f"(the reference is the main job's loading at 10 m/s); a step of 0.7 instead of 0.8 of the stable one "
        f"changes it by {100 * (step['load'] / l3['load'] - 1):+.3f} %.",
    ]
    # Particles across a for 1, 2 and 5 %: the fewest from which every run
    # of the default gap with 3 levels' boxes or fewer (not the 4- and
    # 5-level runs, whose boxes close in on the tip) is within the bound.
    fam = [r for r in runs if not r["name"].startswith(("nearest_", "levels_4", "levels_5"))]
    bounds = []
    for b in (0.01, 0.02, 0.05):
        ok = [r["particles_across_a"] for r in fam
              if all(abs(q["error"]) <= b for q in fam if q["particles_across_a"] >= r["particles_across_a"])]
        bounds.append(f"{100 * b:.0f} %: {min(ok):.1f}" if ok else f"{100 * b:.0f} %: none")
    worst = sorted(fam, key=lambda r: r["particles_across_a"])
    checks.append(
        "Particles across a for a bound on the load (the fewest from which every run above with 3 levels' boxes or "
        "fewer stays within it): " + ", ".join(bounds) + ". By particles across a: "
        + ", ".join(f"{r['particles_across_a']:.1f} → {100 * r['error']:+.1f} %" for r in worst)
        + ". Below 4 particles the error is not monotone (one particle across can land closer than two; the "
        "measured half-width is never below one particle). `wedge_indentation --across 3.5` "
        "(gimlet_propose_levels: expected a 220 nm, 3 levels) proposes the main job's 1 % layout (measured "
        "2026-11-28: 8507.3 N/m against the main job's 8508.5).")
    for c in checks:
        print("  " + c)
    study = {
        "date": datetime.date.today().isoformat(),
        "commit": logged_run.source_commit(ROOT),
        "ranks": o.np,
        "reference": {"load": ref, "order": p, "how": how, "orders_along_curve": orders,
                      "nearest_gap": {"extrapolated_observed_order": ref_n, "order": p_n,
                                      "extrapolated_first_order": ref_n1}, "a_half_space_m": a_ref},
        "runs": [{k: v for k, v in r.items() if k != "curve"} for r in runs],
        "checks": checks,
    }
    os.makedirs(o.out, exist_ok=True)
    with open(os.path.join(o.out, "wedge_work_precision.json"), "w") as f:
        json.dump(study, f, indent=1)
    keys = ["name", "args", "ranks", "levels", "finest_cell_nm", "particles", "steps", "particles_across_a",
            "a_m", "load", "error", "curve_max", "curve_rms", "wall_s"]
    with open(os.path.join(o.out, "wedge_work_precision.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(keys + ["profile_rms"])
        for r in runs:
            w.writerow([r[k] for k in keys] + [r["profile"]["rms"]])
    plot(runs, os.path.join(o.out, "wedge_work_precision.png"))
    if not o.no_docs:
        write_docs(study, os.path.join(ROOT, "README.md"))
        with open(os.path.join(ROOT, "docs", "wedge_work_precision.json"), "w") as f:
            json.dump(study, f, indent=1)
        print("updated README.md (the work-precision table) and docs/wedge_work_precision.json")
    print(f"wrote {o.out}/wedge_work_precision.csv, .json, .png")


def plot(runs, path):
    try:
        import matplotlib
    except ImportError:
        print("matplotlib missing: no plot")
        return
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.8))
    lv = [r for r in runs if re.fullmatch(r"levels_\d", r["name"])]
    ax.loglog([r["wall_s"] for r in lv], [abs(r["error"]) for r in lv], "o-", label="load at 450 nm, levels")
    ax.loglog([r["wall_s"] for r in lv], [r["curve_rms"] for r in lv], "s--", label="loading curve RMS, levels")
    for r in lv:
        ax.annotate(f"{r['levels']} lv, {r['particles_across_a']:.1f} across a", (r["wall_s"], abs(r["error"])),
                    textcoords="offset points", xytext=(6, 4), fontsize=8)
    for r in runs:
        if r not in lv and not r["name"].startswith("nearest_"):
            ax.loglog([r["wall_s"]], [abs(r["error"])], "^", label=r["label"])
    ax.set_xlabel("wall time on 2 ranks (s)")
    ax.set_ylabel("|relative error| against the reference")
    ax.set_title("main job (65° wedge, 450 nm): load error against wall time")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
