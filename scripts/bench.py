#!/usr/bin/env python3
"""The benchmark of issue 12 item 3, in one sitting (`make bench`).

Runs, from the repository root after `make examples`:

  comparison  the peers' comparison scene (512 x 512 cells, 262,144
              particles, 200 steps), examples-c/bench_scene through the C API,
              uGIMP with USL and with MUSL, on 1 and on 2 ranks;
  block_1m    the same scene at 1024 x 1024 cells (1,048,576 particles),
              100 steps (half the comparison scene's, to keep the sitting
              short: the rate does not depend on the step count beyond the
              warm-up), USL and MUSL, 1 and 2 ranks;
  levels      examples-c/levels_speed: the 3-level pressure indentation and
              its uniform-finest twin (300 coarse steps), 1 and 2 ranks, with
              the stress error against the uniform-finest run;
  wedge       the contact scene: examples-c/wedge_indentation (the main job,
              3 levels, PETSc contact solves) pushed to 100 nm without
              unloading, 1 and 2 ranks; its error is the load at 100 nm on 2
              ranks against the 1-rank run (results must not depend on the
              rank count);
  kernel      (reference line, NOT the C API) gimlet-bench: the comparison
              scene on the internal single-patch Solver, when the binary is
              there; the Solver runs the same step as gimlet_step's levels
              (kernel::step_patches) on one patch, without MPI and without
              the C API's checks and transactions, so the gap between this
              line and the 1-rank C API line is that overhead;
  peers       the peer codes' runner given by --peers (`make bench` passes
              the one it finds), run as `RUNNER 512 4 200` (Warp, Taichi on
              1 and 2 threads), and our rate over each peer's: the
              comparison scene's repetitions are interleaved with the peers'
              (ours, then the peers, RUNS times), so that each ratio is
              taken within a minute on a shared machine; the median of the
              per-repetition ratios is reported.

Every case of ours is run RUNS times (default 3) and the medians are taken.
Prints a table and the targets of the issue (reported, not asserted), and
writes results/bench.json; scripts/bench_docs.py turns that into the
speed table of docs/performance.md.

  scripts/bench.py [--build build] [--out results/bench.json] [--runs 3]
                   [--peers RUNNER|none] [--kernel-exe PATH] [--quick]

--quick: small sizes and one run each, to check the script itself (the
figures mean nothing; the JSON is marked "quick").
"""
import argparse
import datetime
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def log(msg):
    print(msg, flush=True)


def load():
    return [round(x, 2) for x in os.getloadavg()]


def run(cmd, env=None):
    """Runs cmd, returns its stdout; on failure prints its output and exits."""
    t0 = time.time()
    p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    if p.returncode != 0:
        log(f"FAILED (exit {p.returncode}): {' '.join(cmd)}\n{p.stdout}\n{p.stderr}")
        sys.exit(1)
    return p.stdout, time.time() - t0


def run_pair(cmd):
    """Runs two copies of cmd at once (independent processes, no
    communication between them); returns their stdouts."""
    ps = [subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
          for _ in range(2)]
    outs = [p.communicate() for p in ps]
    for p, (o, e) in zip(ps, outs):
        if p.returncode != 0:
            log(f"FAILED (exit {p.returncode}): {' '.join(cmd)} (pair)\n{o}\n{e}")
            sys.exit(1)
    return [o for o, _ in outs]


def json_lines(text):
    out = []
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("{") and line.endswith("}"):
            out.append(json.loads(line))
    return out


def mpiexec(n, exe, *args):
    return ["mpiexec", "-n", str(n), exe, *args]


def peers_script(arg):
    """The peer codes' runner named by --peers (empty or "none": none)."""
    if not arg or arg == "none":
        return None
    if os.path.isfile(arg) and os.access(arg, os.X_OK):
        return os.path.abspath(arg)
    log(f"  peers: {arg} is not an executable file, skipped")
    return None


def git_describe():
    def g(*a):
        return subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    return {"commit": g("rev-parse", "HEAD"), "branch": g("rev-parse", "--abbrev-ref", "HEAD"),
            "dirty": bool(g("status", "--porcelain", "--untracked-files=no"))}


def fmt_rate(r):
    return f"{r / 1e6:.2f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("BUILD", "build"))
    ap.add_argument("--out", default="results/bench.json")
    ap.add_argument("--runs", type=int, default=None, help="runs per case (default 3; 1 with --quick)")
    ap.add_argument("--peers", default=os.environ.get("PEERS", ""))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--kernel-exe", default="",
                    help="gimlet-bench binary (default: $CARGO_TARGET_DIR or BUILD/cargo, release/gimlet-bench)")
    a = ap.parse_args()
    runs = a.runs if a.runs is not None else 1 if a.quick else 3
    if runs < 1:
        sys.exit("--runs must be >= 1")
    ex = os.path.join(ROOT, a.build, "examples-c")
    for exe in ("bench_scene", "levels_speed", "wedge_indentation"):
        if not os.access(os.path.join(ex, exe), os.X_OK):
            sys.exit(f"{ex}/{exe} is missing: run `make examples` first (make bench does)")
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, a.build, "cargo"))
    kernel_exe = a.kernel_exe or os.path.join(target, "release", "gimlet-bench")
    t_start = time.time()
    sitting = {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "host": platform.node(), "cpu_count": os.cpu_count(), "load_start": load(),
        "git": git_describe(), "runs": runs, "quick": a.quick,
    }
    try:
        with open("/proc/cpuinfo") as f:
            sitting["cpu"] = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), "")
    except OSError:
        pass
    log(f"=== make bench: {sitting['date']} on {sitting['host']} ({sitting['cpu_count']} cores, "
        f"{sitting.get('cpu', '')}), load {sitting['load_start']}, medians of {runs} run(s)")
    cases = []

    def report(r, el, l0):
        log(f"  {r['case']:<10} {r['scheme']:<4} {r['ranks']} rank(s): {r['particles']} particles, {r['steps']} "
            f"steps, wall {r['wall_s']:.3f} s (runs {r['walls']}), {fmt_rate(r['pstep_per_s'])} M p-steps/s, "
            f"{fmt_rate(r['pstep_per_s_per_core'])} per core; momentum err {r['momentum_rel_err']}, "
            f"com fall err {r['com_fall_rel_err']} [{el:.0f} s, load {l0[0]}]")
        if r.get("phase_max_s"):
            log("             timed steps (largest / smallest over ranks): "
                + ", ".join(f"{nm} {a:.3f}/{b:.3f} s" for nm, a, b in
                            zip(r["phase_names"], r["phase_max_s"], r["phase_min_s"]) if a > 0))

    configs = [(scheme, n) for scheme in ("usl", "musl") for n in (1, 2)]
    # What hosts run, beside the uGIMP/USL/FLIP line above: the library's
    # default, the like-for-like match of Warp's affine MLS-MPM, and the
    # paper's scheme (the main job's), in the same repetitions.
    user_configs = [
        ("default", "the library's default (cpGIMP, MUSL, APIC)",
         ["--shape", "cpgimp", "--scheme", "musl", "--transfer", "apic"], (1, 2)),
        ("ugimp_usl_apic", "uGIMP, USL, APIC (like Warp's affine transfer)",
         ["--shape", "ugimp", "--scheme", "usl", "--transfer", "apic"], (1,)),
        ("paper", "the paper's and the main job's (uGIMP, MUSL, FLIP)",
         ["--shape", "ugimp", "--scheme", "musl", "--transfer", "flip"], (1,)),
        # The axisymmetric mode (issue 28): the same scene with x the radius,
        # against its plane-strain twins of the same repetitions.
        ("axi_usl_flip", "axisymmetric uGIMP, USL, FLIP",
         ["--geometry", "axisym", "--shape", "ugimp", "--scheme", "usl", "--transfer", "flip"], (1,)),
        ("axi_default", "axisymmetric, the library's default (cpGIMP, MUSL, APIC)",
         ["--geometry", "axisym", "--shape", "cpgimp", "--scheme", "musl", "--transfer", "apic"], (1,)),
    ]
    user_reps = {(k, n): [] for k, _, _, ns in user_configs for n in ns}
    script = peers_script(a.peers)
    pa = ["64", "4", "20"] if a.quick else ["512", "4", "200"]
    cells, steps = (64, 20) if a.quick else (512, 200)

    # --- the comparison scene through the C API, interleaved with the peers -
    # Each repetition runs the four configurations once, then the peer codes
    # once: the ratios are taken repetition by repetition (the same minute of
    # a shared machine) and their medians reported.
    if script:
        log(f"  peers: {script} {' '.join(pa)} after each repetition (the first call installs Taichi and Warp)")
    else:
        log("  peers: no runner given (--peers), skipped")
    comp_reps = {c: [] for c in configs}
    peer_reps = []
    # The machine's own ceiling for 2 ranks: two independent 1-rank runs at
    # once (no communication, no shared work), each one's rate over the
    # 1-rank run of the same repetition. Cores that share memory bandwidth,
    # caches or a clock budget lose rate here whatever the code does.
    pair_reps = []
    for rep in range(runs):
        for scheme, n in configs:
            l0 = load()
            out, el = run(mpiexec(n, os.path.join(ex, "bench_scene"), "--cells", str(cells), "--steps", str(steps),
                                  "--runs", "1", "--scheme", scheme, "--case", "comparison"))
            r = json_lines(out)[-1]
            r.update(load_before=l0, rep=rep)
            comp_reps[(scheme, n)].append(r)
            report(r, el, l0)
        for key, label, args, ns in user_configs:
            for n in ns:
                l0 = load()
                out, el = run(mpiexec(n, os.path.join(ex, "bench_scene"), "--cells", str(cells), "--steps",
                                      str(steps), "--runs", "1", *args, "--case", "comparison"))
                r = json_lines(out)[-1]
                r.update(load_before=l0, rep=rep, config=key, config_label=label)
                user_reps[(key, n)].append(r)
                log(f"  config     {key:<15} {n} rank(s): {fmt_rate(r['pstep_per_s'])} M p-steps/s "
                    f"[{el:.0f} s, load {l0[0]}]")
        l0 = load()
        # (--bind-to none: each mpiexec would bind its one rank to core 0,
        # and the two runs would share that core.)
        outs = run_pair(["mpiexec", "--bind-to", "none", "-n", "1", os.path.join(ex, "bench_scene"),
                         "--cells", str(cells), "--steps", str(steps), "--runs", "1", "--scheme", "usl",
                         "--case", "comparison"])
        solo = comp_reps[("usl", 1)][-1]
        solo_rate = solo["particles"] * solo["steps"] / solo["wall_s"]
        both = [json_lines(o)[-1] for o in outs]
        rates = [x["particles"] * x["steps"] / x["wall_s"] for x in both]
        pair_reps.append(statistics.mean(rates) / solo_rate)
        log(f"  pair       usl  2 x 1 rank at once: {', '.join(fmt_rate(x) for x in rates)} M p-steps/s each, "
            f"{pair_reps[-1]:.2f} of the 1-rank rate [load {l0[0]}]")
        if script:
            l0 = load()
            out, el = run([script, *pa])
            got = json_lines(out)
            for p in got:
                p.update(load_before=l0, rep=rep)
                log(f"  peer       {p['impl']:<7} {p['threads']} thread(s): {fmt_rate(p['pstep_per_s'])} M "
                    f"p-steps/s (wall {p['wall_s']} s) [load {l0[0]}]")
            peer_reps.append(got)
    for scheme, n in configs:
        rs = comp_reps[(scheme, n)]
        r = dict(rs[-1])
        walls = [x["wall_s"] for x in rs]
        r.update(runs=len(rs), walls=walls, wall_s=statistics.median(walls),
                 cpu_s=statistics.median(x["cpu_s"] for x in rs),
                 load_before=[x["load_before"] for x in rs])
        ps = r["particles"] * r["steps"]
        r.update(pstep_per_s=ps / r["wall_s"], pstep_per_s_per_core=ps / r["wall_s"] / n,
                 pstep_per_cpu_s=ps / r["cpu_s"])
        for k in ("momentum_rel_err", "com_fall_rel_err", "com_discrete_rel_err"):
            vals = [x[k] for x in rs]
            r[k] = None if any(v is None for v in vals) else max(vals)
        cases.append(r)
    for (key, n), rs in user_reps.items():
        r = dict(rs[-1])
        walls = [x["wall_s"] for x in rs]
        ps = r["particles"] * r["steps"]
        r.update(case="comparison_config", runs=len(rs), walls=walls, wall_s=statistics.median(walls),
                 load_before=[x["load_before"] for x in rs])
        r.update(pstep_per_s=ps / r["wall_s"], pstep_per_s_per_core=ps / r["wall_s"] / n)
        cases.append(r)
    peers = []
    if peer_reps:
        for k, p0 in enumerate(peer_reps[0]):
            same = [pr[k] for pr in peer_reps if len(pr) > k and pr[k]["impl"] == p0["impl"]
                    and pr[k]["threads"] == p0["threads"]]
            p = dict(p0)
            p.update(runs=len(same), walls=[x["wall_s"] for x in same],
                     wall_s=statistics.median(x["wall_s"] for x in same),
                     rates=[x["pstep_per_s"] for x in same],
                     load_before=[x["load_before"] for x in same])
            p["pstep_per_s"] = p["particles"] * p["steps"] / p["wall_s"]
            peers.append(p)

    # --- the large block through the C API ----------------------------------
    cells, steps = (128, 10) if a.quick else (1024, 100)
    for scheme, n in configs:
        l0 = load()
        out, el = run(mpiexec(n, os.path.join(ex, "bench_scene"), "--cells", str(cells), "--steps", str(steps),
                              "--runs", str(runs), "--scheme", scheme, "--case", "block_1m"))
        r = json_lines(out)[-1]
        r.update(load_before=l0, load_after=load(), elapsed_s=round(el, 1))
        cases.append(r)
        report(r, el, l0)

    # --- 3 levels against the uniform-finest twin --------------------------
    lsteps = "30" if a.quick else "300"
    for n in (1, 2):
        reps = []
        l0 = load()
        t0 = time.time()
        for _ in range(runs):
            out, _ = run(mpiexec(n, os.path.join(ex, "levels_speed"), lsteps, "--no-table"))
            reps.append(json_lines(out)[-1])
        el = time.time() - t0
        names = [r["name"] for r in reps[0]["runs"]]
        med = {}
        for k, nm in enumerate(names):
            med[nm] = {
                "wall_s": statistics.median(r["runs"][k]["wall_s"] for r in reps),
                "cpu_s": statistics.median(r["runs"][k]["cpu_s"] for r in reps),
                "walls": [r["runs"][k]["wall_s"] for r in reps],
                "particles": reps[0]["runs"][k]["particles"],
                "particle_steps": reps[0]["runs"][k]["particle_steps"],
                "cells": reps[0]["runs"][k]["cells"],
                "stress_diff": reps[0]["runs"][k]["stress_diff"],
            }
            med[nm]["pstep_per_s"] = med[nm]["particle_steps"] / med[nm]["wall_s"]
        ratios = [r["runs"][0]["wall_s"] / r["runs"][1]["wall_s"] for r in reps]
        cpu_ratios = [r["runs"][0]["cpu_s"] / r["runs"][1]["cpu_s"] for r in reps]
        est = reps[0]["fine_error_estimate"]
        r = {"case": "levels", "ranks": n, "coarse_steps": int(lsteps), "runs": med,
             "wall_ratio_median": statistics.median(ratios), "wall_ratios": ratios,
             "cpu_ratio_median": statistics.median(cpu_ratios),
             "fine_error_estimate": est, "error_bound_ratio": reps[0]["error_bound_ratio"],
             "load_before": l0, "load_after": load(), "elapsed_s": round(el, 1)}
        cases.append(r)
        m3, mf = med["3_levels"], med["uniform_0.25um"]
        log(f"  levels     {n} rank(s): 3 levels {m3['wall_s']:.2f} s, uniform 0.25 um {mf['wall_s']:.2f} s, "
            f"ratio {r['wall_ratio_median']:.3f} (runs {', '.join(f'{x:.3f}' for x in ratios)}; CPU time "
            f"{r['cpu_ratio_median']:.3f}), stress diff "
            f"{m3['stress_diff']:.3e} + estimate {est:.3e} = {r['error_bound_ratio']:.2f}x the estimate "
            f"[{el:.0f} s, load {l0[0]}]")

    # --- the contact scene -------------------------------------------------
    depth = "1e-7"
    wedge_args = ["--petsc", "--unload", "0", "--quiet", "--depth", depth]
    if a.quick:
        wedge_args += ["--h0", "1e-6", "--levels", "2"]
    tmp = tempfile.mkdtemp(prefix="gimlet-bench-")
    try:
        for n in (1, 2):
            reps = []
            l0 = load()
            t0 = time.time()
            for _ in range(runs):
                out, _ = run(mpiexec(n, os.path.join(ex, "wedge_indentation"), *wedge_args, "--out", tmp))
                reps.append(json_lines(out)[-1])
            el = time.time() - t0
            w = statistics.median(x["wall_s"] for x in reps)
            r = dict(reps[0])
            r.update(wall_s=w, walls=[x["wall_s"] for x in reps], pstep_per_s=r["particle_steps"] / w,
                     load_before=l0, load_after=load(), elapsed_s=round(el, 1), args=wedge_args)
            cases.append(r)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    w1 = next(c for c in cases if c["case"] == "wedge" and c["ranks"] == 1)
    for c in cases:
        if c["case"] == "wedge":
            c["load_rel_diff_vs_1_rank"] = abs(c["load_at_depth_n_per_m"] - w1["load_at_depth_n_per_m"]) / abs(
                w1["load_at_depth_n_per_m"])
            sh = c.get("phase_shares")
            split = ("; time split kernel {:.0%}, contact {:.0%}, exchange {:.0%}, migration {:.0%}, "
                     "coupling {:.0%}".format(*sh)) if sh else ""
            log(f"  wedge      {c['ranks']} rank(s): {c['particles']} particles, {c['steps']} steps to "
                f"{float(depth) * 1e9:.0f} nm, wall {c['wall_s']:.2f} s (runs {c['walls']}), "
                f"{fmt_rate(c['pstep_per_s'])} M p-steps/s; load {c['load_at_depth_n_per_m']:.6g} N/m, "
                f"{c['load_rel_diff_vs_1_rank']:.2e} from 1 rank{split} "
                f"[{c['elapsed_s']:.0f} s, load {c['load_before'][0]}]")

    # --- kernel-only reference line (internal Solver, not the C API) -------
    if os.access(kernel_exe, os.X_OK):
        ks = ["--cells", "64", "--steps", "20"] if a.quick else ["--cells", "512", "--steps", "200"]
        l0 = load()
        out, el = run([kernel_exe, *ks, "--scheme", "usl,musl", "--runs", str(runs)])
        for r in json_lines(out):
            r.update(case="kernel", ranks=1, api="internal Solver (not the C API)", load_before=l0,
                     elapsed_s=round(el, 1))
            cases.append(r)
            log(f"  kernel     {r['scheme']:<4} 1 core (internal Solver, not the C API): "
                f"{fmt_rate(r['pstep_per_wall_s'])} M p-steps/s per wall s, {fmt_rate(r['pstep_per_s'])} per CPU s")
    else:
        log(f"  kernel     skipped: {kernel_exe} not built")

    # --- instructions per particle-step (callgrind), when valgrind is there ---
    # The difference of two runs (STEPS and 2 STEPS timed steps of the same
    # scene at 128^2 cells) over the particle-steps between them: setup and
    # warm-up cancel. Counted on the instruction set valgrind reports (it
    # hides AVX-512), so on an AVX-512 machine it counts the AVX2 path.
    vg = shutil.which("valgrind")
    if vg:
        isteps = 2 if a.quick else 10
        for key, label, args in ([("usl_flip", "uGIMP, USL, FLIP",
                                   ["--shape", "ugimp", "--scheme", "usl", "--transfer", "flip"])]
                                 + [(k, lb, ar) for k, lb, ar, _ in user_configs]):
            irs = []
            for st in (isteps, 2 * isteps):
                with tempfile.TemporaryDirectory() as td:
                    cmd = [vg, "--tool=callgrind", f"--callgrind-out-file={td}/cg.out",
                           os.path.join(ex, "bench_scene"), "--cells", "128", "--steps", str(st), "--warmup", "2",
                           "--runs", "1", *args, "--case", "instructions"]
                    p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
                    if p.returncode != 0:
                        log(f"  instructions: {' '.join(cmd)} failed (exit {p.returncode}), skipped")
                        break
                    ir = next((int(l.split()[-1]) for l in p.stderr.splitlines() if "Collected" in l), None)
                    n = json_lines(p.stdout)[-1]["particles"]
                    irs.append(ir)
            if len(irs) == 2 and None not in irs:
                per = (irs[1] - irs[0]) / (n * isteps)
                cases.append({"case": "instructions", "config": key, "config_label": label, "ranks": 1,
                              "particles": n, "steps": [isteps, 2 * isteps], "instructions": irs,
                              "per_particle_step": per, "counter": "valgrind --tool=callgrind (Ir)"})
                log(f"  instructions {key:<15} {per:.0f} per particle-step (callgrind, {n} particles)")
    else:
        log("  instructions: valgrind not found, skipped (apt-get install valgrind)")

    # --- ratios and targets ---------------------------------------------------
    def ours(case, scheme, n):
        return next((c for c in cases if c["case"] == case and c.get("scheme") == scheme and c["ranks"] == n
                     and c.get("api") == "c"), None)

    ratios = []
    for (scheme, n), rs in comp_reps.items():
        c = ours("comparison", scheme, n)
        for k, p in enumerate(peers):
            per = [(x["particles"] * x["steps"] / x["wall_s"]) / pr[k]["pstep_per_s"]
                   for x, pr in zip(rs, peer_reps) if len(pr) > k]
            ratios.append({"ours": f"C API {scheme} {n} rank(s)",
                           "peer": f"{p['impl']} {p['threads']} thread(s)",
                           "ours_rate": c["pstep_per_s"], "peer_rate": p["pstep_per_s"],
                           "ratio": statistics.median(per), "ratios_per_repetition": per,
                           "same_cores": n == p["threads"]})
    for (key, n), rs in user_reps.items():
        for k, p in enumerate(peers):
            per = [(x["particles"] * x["steps"] / x["wall_s"]) / pr[k]["pstep_per_s"]
                   for x, pr in zip(rs, peer_reps) if len(pr) > k]
            ratios.append({"ours": f"C API {key} {n} rank(s)", "peer": f"{p['impl']} {p['threads']} thread(s)",
                           "ours_rate": statistics.median(x["pstep_per_s"] for x in rs),
                           "peer_rate": p["pstep_per_s"], "ratio": statistics.median(per),
                           "ratios_per_repetition": per, "same_cores": n == p["threads"]})
    targets = []

    def target(what, value, bound, ok, note=""):
        targets.append({"target": what, "value": value, "bound": bound, "met": bool(ok), "note": note})

    u1 = ours("comparison", "usl", 1)
    warp = next((p for p in peers if p["impl"] == "warp"), None)
    if u1 and warp:
        v = next(r["ratio"] for r in ratios if r["ours"] == "C API usl 1 rank(s)" and r["peer"] == "warp 1 thread(s)")
        target("1 rank uGIMP/USL (C API) over Warp CPU, comparison scene", v, ">= 1.2", v >= 1.2,
               "median of the per-repetition ratios")
    if warp:
        for key, bound in (("default", 1.0), ("ugimp_usl_apic", 1.5)):
            v = next((r["ratio"] for r in ratios if r["ours"] == f"C API {key} 1 rank(s)"
                      and r["peer"] == "warp 1 thread(s)"), None)
            if v is not None:
                target(f"1 rank {key} (C API) over Warp CPU, comparison scene", v, f">= {bound}", v >= bound,
                       "median of the per-repetition ratios")
    # Axisymmetric over plane-strain time per particle-step, each against
    # its twin of the same repetitions (issue 28: at most 1.25).
    def config_walls(key):
        return next((c["walls"] for c in cases if c["case"] == "comparison_config" and c["config"] == key
                     and c["ranks"] == 1), None)
    usl1 = ours("comparison", "usl", 1)
    for axi, plane, walls_plane in (("axi_usl_flip", "uGIMP/USL/FLIP", usl1["walls"] if usl1 else None),
                                    ("axi_default", "the default", config_walls("default"))):
        walls_axi = config_walls(axi)
        if walls_axi and walls_plane and len(walls_axi) == len(walls_plane):
            v = statistics.median(x / y for x, y in zip(walls_axi, walls_plane))
            target(f"axisymmetric / plane-strain time, {plane}, comparison 1 rank", v, "<= 1.25", v <= 1.25,
                   "median of the per-repetition ratios")
    d1, d2 = (next((c for c in cases if c["case"] == "comparison_config" and c["config"] == "default"
                    and c["ranks"] == n), None) for n in (1, 2))
    if d1 and d2:
        v = d2["pstep_per_s"] / (2 * d1["pstep_per_s"])
        target("parallel efficiency 2 ranks vs 1, comparison default", v, ">= 0.90", v >= 0.9)
    ceiling = statistics.median(pair_reps) if pair_reps else None
    for case in ("comparison", "block_1m"):
        for scheme in ("usl", "musl"):
            c1, c2 = ours(case, scheme, 1), ours(case, scheme, 2)
            if c1 and c2:
                v = c2["pstep_per_s"] / (2 * c1["pstep_per_s"])
                note = "" if ceiling is None else f"machine ceiling (two independent 1-rank runs at once) {ceiling:.2f}"
                target(f"parallel efficiency 2 ranks vs 1, {case} {scheme}", v, ">= 0.90", v >= 0.9, note)
    for c in cases:
        if c["case"] == "levels":
            target(f"3-level wall / uniform-finest wall, {c['ranks']} rank(s)", c["wall_ratio_median"], "<= 0.30",
                   c["wall_ratio_median"] <= 0.30)
            target(f"3-level stress error bound / uniform-finest error, {c['ranks']} rank(s)",
                   c["error_bound_ratio"], "<= 2", c["error_bound_ratio"] <= 2.0)
    for case in ("comparison", "block_1m"):
        for n in (1, 2):
            u, m = ours(case, "usl", n), ours(case, "musl", n)
            if u and m:
                v = m["wall_s"] / u["wall_s"]
                target(f"MUSL time per step over USL's, {case} {n} rank(s)", v, "<= 1.5", v <= 1.5)

    # The main job's rate against the single-level rate of its scheme (the
    # paper's uGIMP/MUSL/FLIP on the comparison scene, same ranks), and its
    # coupling and contact shares (issue 29).
    for c in cases:
        if c["case"] != "wedge":
            continue
        single = ours("comparison", "musl", c["ranks"])
        if single:
            v = c["pstep_per_s"] / single["pstep_per_s"]
            c["rate_over_single_level"] = v
            target(f"main job (3 levels, to {float(depth) * 1e9:.0f} nm) over the single-level rate of its scheme "
                   f"(uGIMP/MUSL/FLIP comparison scene), {c['ranks']} rank(s)", v, ">= 0.60", v >= 0.6)
        sh = c.get("phase_shares")
        if sh and c["ranks"] == 2:
            target("main job coupling share of the step time, 2 ranks", sh[4], "<= 0.15", sh[4] <= 0.15)
            target("main job contact share of the step time, 2 ranks", sh[1], "<= 0.08", sh[1] <= 0.08)

    sitting.update(load_end=load(), elapsed_s=round(time.time() - t_start, 1))
    result = {"sitting": sitting, "cases": cases, "peers": peers, "ratios": ratios, "targets": targets,
              "pair_ceiling": {"ratios_per_repetition": pair_reps,
                               "median": statistics.median(pair_reps) if pair_reps else None}}

    # --- the table ------------------------------------------------------------
    log("")
    log(f"=== results (one sitting: {sitting['date']}, load {sitting['load_start']} -> {sitting['load_end']} "
        f"on {sitting['cpu_count']} cores, {sitting['elapsed_s']:.0f} s)")
    hdr = f"{'case':<11} {'scheme':<6} {'ranks':>5} {'particles':>10} {'steps':>6} {'wall [s]':>9} " \
          f"{'M p-steps/s':>11} {'per core':>9} {'per CPU s':>9}  error against the reference"
    log(hdr)
    log("-" * len(hdr))
    for c in cases:
        if c["case"] in ("comparison", "block_1m"):
            err = (f"free fall: momentum {c['momentum_rel_err']:.1e}, centre of mass {c['com_fall_rel_err']:.1e} "
                   f"(discrete: {c['com_discrete_rel_err']:.1e})" if c["momentum_rel_err"] is not None else "-")
            log(f"{c['case']:<11} {c['scheme']:<6} {c['ranks']:>5} {c['particles']:>10} {c['steps']:>6} "
                f"{c['wall_s']:>9.3f} {fmt_rate(c['pstep_per_s']):>11} {fmt_rate(c['pstep_per_s_per_core']):>9} "
                f"{fmt_rate(c['pstep_per_cpu_s']):>9}  {err}")
        elif c["case"] == "levels":
            for nm, label in (("3_levels", "3 levels"), ("uniform_0.25um", "uniform")):
                m = c["runs"][nm]
                err = (f"stress {m['stress_diff']:.2e} from uniform finest (its own error ~{c['fine_error_estimate']:.2e})"
                       if nm == "3_levels" else f"reference; own error ~{c['fine_error_estimate']:.2e} "
                                                f"(from the 0.5 um run)")
                steps = c["coarse_steps"] * (1 if nm == "3_levels" else 4)
                log(f"{'pressure':<11} {label:<6} {c['ranks']:>5} {m['particles']:>10} {steps:>6} {m['wall_s']:>9.3f} "
                    f"{fmt_rate(m['pstep_per_s']):>11} {fmt_rate(m['pstep_per_s'] / c['ranks']):>9} "
                    f"{fmt_rate(m['particle_steps'] / m['cpu_s']):>9}  {err}")
        elif c["case"] == "wedge":
            err = ("reference (load %.6g N/m at %.0f nm)" % (c["load_at_depth_n_per_m"], c["depth_m"] * 1e9)
                   if c["ranks"] == 1 else f"load {c['load_rel_diff_vs_1_rank']:.1e} from the 1-rank run")
            log(f"{'wedge':<11} {'musl':<6} {c['ranks']:>5} {c['particles']:>10} {c['steps']:>6} {c['wall_s']:>9.3f} "
                f"{fmt_rate(c['pstep_per_s']):>11} {fmt_rate(c['pstep_per_s'] / c['ranks']):>9} {'-':>9}  {err}")
        elif c["case"] == "kernel":
            log(f"{'kernel*':<11} {c['scheme']:<6} {1:>5} {c['particles']:>10} {c['steps']:>6} "
                f"{c['particles'] * c['steps'] / c['pstep_per_wall_s']:>9.3f} {fmt_rate(c['pstep_per_wall_s']):>11} "
                f"{fmt_rate(c['pstep_per_wall_s']):>9} {fmt_rate(c['pstep_per_s']):>9}  (internal Solver, not the C API)")
    for p in peers:
        log(f"{'peer':<11} {p['impl'][:6]:<6} {p['threads']:>5} {p['particles']:>10} {p['steps']:>6} "
            f"{p['wall_s']:>9.3f} {fmt_rate(p['pstep_per_s']):>11} {fmt_rate(p['pstep_per_s'] / p['threads']):>9} "
            f"{'-':>9}  "
            f"({p['threads']} thread(s), f64, MLS-MPM)")
    log("multi-level rates count each level's owned particles once per step of that level; per CPU s: over the "
        "CPU time summed over ranks (less sensitive to other load than wall time; includes MPI waits); "
        "kernel*: reference line")
    if ratios:
        log("")
        log("our rate over each peer's (comparison scene; medians of the rates, and the median of the ratios taken "
            "repetition by repetition):")
        for r in ratios:
            log(f"  {r['ours']:<24} / {r['peer']:<20} {fmt_rate(r['ours_rate']):>7} / {fmt_rate(r['peer_rate']):>7}"
                f", ratio {r['ratio']:.2f} (repetitions {', '.join(f'{x:.2f}' for x in r['ratios_per_repetition'])})"
                f"{'' if r['same_cores'] else '  (different core counts)'}")
    if pair_reps:
        log("")
        log(f"the machine's ceiling for 2 ranks: two independent 1-rank USL runs at once each reach "
            f"{statistics.median(pair_reps):.2f} of the 1-rank rate (repetitions "
            f"{', '.join(f'{x:.2f}' for x in pair_reps)}): the 2-rank efficiency cannot exceed it")
    log("")
    log("targets (reported, not asserted):")
    for t in targets:
        log(f"  {t['target']:<66} {t['value']:.3f} ({t['bound']}): {'met' if t['met'] else 'NOT met'}"
            f"{'; ' + t['note'] if t['note'] else ''}")
    os.makedirs(os.path.dirname(os.path.join(ROOT, a.out)) or ".", exist_ok=True)
    with open(os.path.join(ROOT, a.out), "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")
    log(f"\nwrote {a.out}")


if __name__ == "__main__":
    main()
