#!/usr/bin/env python3
"""Friction study of the J2 wedge nanoindentation: the 65 deg wedge pushed
600 nm into the J2 aluminium half block at 20 m/s and withdrawn at 2 m/s
(examples-c/wedge_indentation.c --material j2 at the resolution of its J2
validation row in docs/validation.md: cells 1000/500/250 nm, finest box
8 um), loaded and unloaded, with Coulomb friction mu = 0, 0.1, 0.2 and 0.3
at the wedge (--friction), on 2 ranks.

For each mu: the load at the final depth, the pile-up (the highest point of
the top particle row above the original surface within 5 um of the axis,
after unloading), the impression's depth, the residual depth (the tip's
depth where the unloading load returns to zero, from the unloading
analysis), and hardness and reduced modulus from the example's unloading
analysis with the contact half-width from Oliver-Pharr's contact depth
(gimlet_indentation_analysis_wedge) and with the half-width measured from
the particles in contact (gimlet_indentation_analysis); also the friction
dissipation and, at the deepest point, the tangential side of the contact
(the particles that stick, the tangential force on the body along the
flank). About 80 s on 2 cores.

The frictional solves run with the library's settings (tolerance 1e-8,
at most 200 friction-bound iterations; --max-iter N passes
wedge_indentation --friction-max-iter N); the table gives the mean and the
most iterations of a solve in each run.

With --scene cone, the axisymmetric 70.3 deg cone instead
(examples-c/cone_indentation.c, J2 aluminium by default, pushed 300 nm at
10 m/s, held, withdrawn at 0.5 m/s; --cone-levels 3 by default: cells of
503/251/126 nm, 13 finest particles across a_g = h tan(psi), 20,224
particles) with --friction mu. For each mu: the load at the final depth
(after the hold, the start of unloading) and the largest load on the way,
the loading curvature C = P/h^2 (least squares over the second half of the
loading: it averages the staircase of the rings entering the contact), the
pile-up of the top particle row after unloading (and under load), the
impression's depth at the axis, the residual depth h_f of the unloading fit,
Oliver-Pharr's hardness and reduced modulus (gimlet_indentation_analysis_axisym)
and the same with the true contact area (the outer edge of the outermost
loaded contact face over the hold), their area ratio, the friction
dissipation (the whole body's, J) and, at the end of the constant-speed
push (the cone moving) and at the start of unloading (after the hold), the
particles that stick and the tangential over the normal force along the
flank. About 2 minutes on 1 core (the same figures on 2 ranks).

  scripts/friction_study.py [--scene wedge|cone] [--np N] [--out DIR] [--build DIR] [--exe PATH]
                            [--mu 0,0.1,0.2,0.3] [--max-iter N] [--cone-levels L] [--no-docs] [--reuse]

Writes DIR/friction_study.csv (one row per mu), the runs' outputs under
DIR/friction_study/mu_<mu>/ and, unless --no-docs, the generated table of
README.md (between its friction-study markers); with --scene cone
DIR/friction_study_cone.csv, DIR/friction_study_cone/mu_<mu>/ and the
table between README.md's friction-study-cone markers.
"""
import argparse
import csv
import datetime
import json
import os
import re
import sys

import logged_run

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BEGIN = "<!-- friction-study:begin"
END = "<!-- friction-study:end -->"
E, NU = 70e9, 0.33
E_STAR = E / (1 - NU * NU)
# The J2 validation row of docs/validation.md (the twin-checked layout).
J2_ARGS = ["--material", "j2", "--levels", "3", "--h0", "1e-6", "--depth", "6e-7", "--speed", "20",
           "--unload-speed", "2", "--ramp", "2e-8", "--box", "16e-6"]
PILE_UP_WITHIN = 5e-6  # "next to the contact": the pile-up is sought within this distance of the axis
# The cone (--scene cone): cone_indentation's J2 run on --cone-levels levels.
CONE_BEGIN = "<!-- friction-study-cone:begin"
CONE_END = "<!-- friction-study-cone:end -->"
CONE_ARGS = ["--material", "j2"]


def number(pattern, text, name):
    m = re.search(pattern, text)
    if not m:
        sys.exit(f"friction_study: no {name} in the output (pattern {pattern!r})")
    return float(m.group(1))


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def run_logged(cmd, d, what, reuse):
    """`logged_run.run_logged` for this study."""
    return logged_run.run_logged(cmd, d, what, reuse, "friction_study")


def run(exe, np_, mu, out, max_iter, reuse=False):
    name = "mu_" + mu
    d = os.path.join(out, "friction_study", name)
    os.makedirs(d, exist_ok=True)
    cmd = (["mpiexec", "-n", str(np_), exe, "--petsc", "--quiet", "--out", d, "--friction", mu]
           + (["--friction-max-iter", str(max_iter)] if max_iter else []) + J2_ARGS)
    stdout = run_logged(cmd, d, f"mu = {mu}", reuse)
    js = next(json.loads(line) for line in stdout.splitlines() if line.startswith('{"case":"wedge"'))
    r = {"mu": mu, "mu_value": float(mu), "wall_s": js["wall_s"], "steps": js["steps"],
         "load": js["load_at_depth_n_per_m"], "a_at_depth_m": js["contact_half_width_m"],
         "dissipation_j_per_m": js.get("friction_dissipation_j_per_m", float("nan"))}
    # The unloading analyses (the example's summary).
    r["p_max"] = number(r"P_max ([0-9.e+-]+) N/m at depth", stdout, "P_max")
    r["a_measured_m"] = number(r"contact half-width a ([0-9.e+-]+) nm \(", stdout, "measured half-width") * 1e-9
    r["h_measured_gpa"] = number(r"hardness H = P_max / 2a = ([0-9.e+-]+) GPa", stdout, "hardness")
    r["er_measured_gpa"] = number(r"reduced modulus E_r = ([0-9.e+-]+) GPa; E/", stdout, "reduced modulus")
    r["h_residual_m"] = number(r"residual depth \(tip depth where the load returns to zero\) ([0-9.e+-]+) nm",
                               stdout, "residual depth") * 1e-9
    m = re.search(r"a ([0-9.e+-]+) nm, hardness H = ([0-9.e+-]+) GPa, reduced modulus E_r = ([0-9.e+-]+) GPa",
                  stdout)
    if not m:
        sys.exit(f"friction_study: mu = {mu}: no Oliver-Pharr analysis in the output:\n{stdout}")
    r["a_op_m"], r["h_op_gpa"], r["er_op_gpa"] = float(m.group(1)) * 1e-9, float(m.group(2)), float(m.group(3))
    m = re.search(r"(\d+) frictional solves, ([0-9.]+) friction-bound iterations per solve, at most (\d+)",
                  stdout)
    r["friction_solves"] = int(m.group(1)) if m else 0
    r["friction_iterations"] = float(m.group(2)) if m else 0.0
    r["friction_iterations_max"] = int(m.group(3)) if m else 0
    # The residual impression: the top particle row after unloading.
    surf = read_csv(os.path.join(d, "nanoindentation_surface.csv"))
    near = [s for s in surf if float(s["x_m"]) <= PILE_UP_WITHIN]
    top = max(near, key=lambda s: float(s["uy_m"]))
    low = min(surf, key=lambda s: float(s["uy_m"]))
    r["pile_up_m"], r["pile_up_x_m"] = float(top["uy_m"]), float(top["x_m"])
    r["impression_m"] = -float(low["uy_m"])
    # The contact at the deepest point: tangential tractions on the body along
    # t = (-n_y, n_x), which on the right flank points up the flank, away from
    # the axis. Friction that resists the material's outward flow pulls it
    # down the flank: negative traction.
    tip = read_csv(os.path.join(d, "nanoindentation_tip.csv"))
    loaded = [c for c in tip if float(c["pressure_pa"]) > 0]
    r["contacts_at_depth"] = len(loaded)
    if loaded and "traction_pa" in loaded[0]:
        r["sticking_at_depth"] = sum(int(c["stick"]) for c in loaded)
        r["tangential_force_n_per_m"] = 2 * sum(float(c["traction_pa"]) * float(c["face_length_m"]) for c in loaded)
        r["normal_force_n_per_m"] = 2 * sum(float(c["pressure_pa"]) * float(c["face_length_m"]) for c in loaded)
        r["traction_outward"] = sum(1 for c in loaded if float(c["traction_pa"]) > 0)
    else:
        r["sticking_at_depth"] = r["traction_outward"] = 0
        r["tangential_force_n_per_m"] = r["normal_force_n_per_m"] = float("nan")
    print(f"  mu {mu:>4s}: load at 600 nm {r['load']:8.2f} N/m, pile-up {r['pile_up_m'] * 1e9:6.1f} nm at "
          f"{r['pile_up_x_m'] * 1e6:.2f} um, residual depth {r['h_residual_m'] * 1e9:6.1f} nm, "
          f"H {r['h_op_gpa']:.4f} GPa, E_r {r['er_op_gpa']:.2f} GPa, {r['wall_s']:.1f} s", flush=True)
    return r


def table(rows):
    """The Markdown table (the README's and the one printed)."""
    out = ["| μ | load at 600 nm | pile-up (at x) | residual depth h_f | H, E_r (Oliver–Pharr a) "
           "| H, E_r (measured a) | sticking at 600 nm, t/p | friction dissipation (full body) "
           "| friction-bound iterations per solve: mean / most | wall (2 ranks) |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        fn = r["normal_force_n_per_m"]
        tn = r["tangential_force_n_per_m"] / fn if fn > 0 else float("nan")
        out.append(
            f"| {r['mu']} | {r['load']:.1f} N/m | **{r['pile_up_m'] * 1e9:.1f} nm** ({r['pile_up_x_m'] * 1e6:.2f} µm) "
            f"| {r['h_residual_m'] * 1e9:.1f} nm "
            f"| {r['h_op_gpa']:.4f} GPa, {r['er_op_gpa']:.2f} GPa ({100 * (r['er_op_gpa'] * 1e9 / E_STAR - 1):+.1f} %) "
            f"| {r['h_measured_gpa']:.4f} GPa, {r['er_measured_gpa']:.2f} GPa "
            f"| {r['sticking_at_depth']} of {r['contacts_at_depth']}, {tn:+.3f} "
            f"| {r['dissipation_j_per_m'] * 1e6:.3g} µJ/m "
            f"| {r['friction_iterations']:.1f} / {r['friction_iterations_max']} | {r['wall_s']:.0f} s |")
    return out


def findings(rows):
    """The trends in one line each, from the numbers."""
    pu = [r["pile_up_m"] for r in rows]
    falls = all(b < a for a, b in zip(pu, pu[1:]))
    mus = ", ".join(r["mu"] for r in rows)

    def series(key, fmt, scale=1.0):
        return ", ".join(fmt.format(r[key] * scale) for r in rows)

    return [
        f"μ = {mus}: pile-up {series('pile_up_m', '{:.1f}', 1e9)} nm "
        + ("(falls at every step)" if falls else "(**does not fall at every step**)")
        + f"; impression {series('impression_m', '{:.0f}', 1e9)} nm deep; measured contact half-width "
        f"{series('a_measured_m', '{:.0f}', 1e9)} nm against Oliver–Pharr's {series('a_op_m', '{:.0f}', 1e9)} nm.",
        f"Load at 600 nm {series('load', '{:.0f}')} N/m (P_max {series('p_max', '{:.0f}')} N/m); residual depth "
        f"{series('h_residual_m', '{:.1f}', 1e9)} nm.",
    ]


def write_docs(study, readme):
    out = [f"{BEGIN} (generated by scripts/friction_study.py, `make friction-study`; do not edit) -->",
           f"Generated by `make friction-study` ({study['date']}, commit {study['commit']}, {study['ranks']} ranks): "
           f"`wedge_indentation {' '.join(J2_ARGS)} --friction μ"
           + (f" --friction-max-iter {study['max_iter']}" if study["max_iter"] else "") + "` (the J2 "
           f"row of docs/validation.md: 65° wedge to 600 nm at 20 m/s, withdrawn at 2 m/s, cells 1000/500/250 nm). "
           f"Pile-up: the top particle row's highest point within {PILE_UP_WITHIN * 1e6:g} µm of the axis after "
           f"unloading; E_r against E/(1 − ν²) = {E_STAR / 1e9:.2f} GPa; t/p: the tangential force on the body "
           f"along the flank's upward tangent over the normal force, at 600 nm (negative: towards the tip).",
           ""] + table(study["runs"]) + [""] + [f"- {c}" for c in study["findings"]] + [END]
    text = open(readme).read()
    i, j = text.find(BEGIN), text.find(END)
    if i < 0 or j < 0:
        sys.exit(f"friction_study: {readme} has no {BEGIN} ... {END} markers")
    with open(readme, "w") as f:
        f.write(text[:i] + "\n".join(out) + text[j + len(END):])


def cone_args(levels):
    return CONE_ARGS + (["--levels", str(levels)] if levels else [])


def run_cone(exe, np_, mu, out, max_iter, levels, reuse=False):
    d = os.path.join(out, "friction_study_cone", "mu_" + mu)
    os.makedirs(d, exist_ok=True)
    cmd = (["mpiexec", "-n", str(np_), exe, "--quiet", "--out", d, "--friction", mu]
           + (["--friction-max-iter", str(max_iter)] if max_iter else []) + cone_args(levels))
    stdout = run_logged(cmd, d, f"cone, mu = {mu}", reuse)
    js = next(json.loads(line) for line in stdout.splitlines() if line.startswith('{"case":"cone"'))
    if js["hardness_pa"] is None:
        sys.exit(f"friction_study: cone, mu = {mu}: the Oliver-Pharr analysis failed:\n{stdout}")
    r = {"mu": mu, "mu_value": float(mu)}
    for k in ["wall_s", "steps", "levels", "particles", "finest_cell_m", "depth_m", "p_max_n", "h_max_m",
              "c_fit_pa", "fit_m", "stiffness_n_per_m", "contact_depth_m", "hardness_pa", "reduced_modulus_pa",
              "residual_depth_m", "area_m2", "true_contact_radius_m", "true_area_m2", "true_hardness_pa",
              "true_reduced_modulus_pa", "area_ratio", "pileup_m", "pileup_at_load_m", "impression_depth_m",
              "kinetic_over_work", "input_reduced_modulus_pa", "friction_dissipation_j",
              "friction_dissipation_at_push_j", "friction_dissipation_at_unload_j", "friction_solves",
              "friction_iterations", "friction_iterations_max", "push_depth_m", "contacts_at_push",
              "sticking_at_push", "tangential_over_normal_at_push", "contacts_at_unload", "sticking_at_unload",
              "tangential_over_normal"]:
        v = js.get(k)
        r[k] = float("nan") if v is None else v
    r["largest_load_n"] = number(r"\(largest load ([0-9.e+-]+) mN\)", stdout, "largest load") * 1e-3
    r["pileup_r_m"] = number(r"pile-up [+-][0-9.]+ nm at r = ([0-9.e+-]+) nm", stdout, "pile-up radius") * 1e-9
    r["work_at_unload_j"] = number(r"at the start of unloading \(work ([0-9.e+-]+) nJ", stdout, "work") * 1e-9
    print(f"  mu {mu:>4s}: load at {r['depth_m'] * 1e9:.0f} nm {r['p_max_n'] * 1e3:.4f} mN, pile-up "
          f"{r['pileup_m'] * 1e9:5.1f} nm at {r['pileup_r_m'] * 1e9:.0f} nm, residual depth "
          f"{r['residual_depth_m'] * 1e9:5.1f} nm, H {r['hardness_pa'] / 1e9:.4f} GPa, "
          f"E_r {r['reduced_modulus_pa'] / 1e9:.2f} GPa, H_true {r['true_hardness_pa'] / 1e9:.4f} GPa, "
          f"dissipation {r['friction_dissipation_j'] * 1e12:.3f} pJ, {r['wall_s']:.1f} s", flush=True)
    return r


def table_cone(rows, ranks):
    """The cone's Markdown table (the README's and the one printed)."""
    es = rows[0]["input_reduced_modulus_pa"]
    h = rows[0]["depth_m"] * 1e9
    hp = rows[0]["push_depth_m"] * 1e9
    out = [f"| μ | load at {h:.0f} nm (largest on the way) | C = P/h² | pile-up after unloading (at r; under load) "
           "| residual depth h_f; impression at the axis | H, E_r (Oliver–Pharr) | H, E_r (true area) "
           f"| true / OP area | sticking, t/p: pushing at {hp:.0f} nm; after the hold "
           "| friction dissipation (whole body; of the work) "
           f"| frictional solves, iterations mean / most | wall ({ranks} rank{'s' if ranks > 1 else ''}) |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        w = r["work_at_unload_j"]
        out.append(
            f"| {r['mu']} | {r['p_max_n'] * 1e3:.4f} mN ({r['largest_load_n'] * 1e3:.4f}) "
            f"| {r['c_fit_pa'] / 1e9:.2f} GPa "
            f"| **{r['pileup_m'] * 1e9:.1f} nm** ({r['pileup_r_m'] * 1e9:.0f} nm; {r['pileup_at_load_m'] * 1e9:.1f} nm) "
            f"| {r['residual_depth_m'] * 1e9:.1f} nm; {r['impression_depth_m'] * 1e9:.1f} nm "
            f"| {r['hardness_pa'] / 1e9:.4f} GPa, {r['reduced_modulus_pa'] / 1e9:.2f} GPa "
            f"({100 * (r['reduced_modulus_pa'] / es - 1):+.1f} %) "
            f"| {r['true_hardness_pa'] / 1e9:.4f} GPa, {r['true_reduced_modulus_pa'] / 1e9:.2f} GPa "
            f"({100 * (r['true_reduced_modulus_pa'] / es - 1):+.1f} %) "
            f"| {r['area_ratio']:.3f} "
            f"| {r['sticking_at_push']} of {r['contacts_at_push']}, {r['tangential_over_normal_at_push']:+.3f}; "
            f"{r['sticking_at_unload']} of {r['contacts_at_unload']}, {r['tangential_over_normal']:+.3f} "
            f"| {r['friction_dissipation_j'] * 1e12:.3g} pJ ({100 * r['friction_dissipation_at_unload_j'] / w:.2f} %) "
            f"| {r['friction_solves']}, {r['friction_iterations'] / max(r['friction_solves'], 1):.1f} / "
            f"{r['friction_iterations_max']} | {r['wall_s']:.0f} s |")
    return out


def findings_cone(rows):
    """The cone's trends in one line each, from the numbers."""
    pu = [r["pileup_m"] for r in rows]
    falls = all(b < a for a, b in zip(pu, pu[1:]))
    mus = ", ".join(r["mu"] for r in rows)
    base = rows[0]

    def series(key, fmt, scale=1.0):
        return ", ".join(fmt.format(r[key] * scale) for r in rows)

    def rel(key):
        return ", ".join(f"{100 * (r[key] / base[key] - 1):+.1f}" for r in rows[1:])

    diss = [r["friction_dissipation_j"] for r in rows if r["mu_value"] > 0]
    grows = all(b > a for a, b in zip(diss, diss[1:]))
    return [
        f"μ = {mus}: pile-up after unloading {series('pileup_m', '{:.1f}', 1e9)} nm "
        + ("(falls at every step)" if falls else "(**does not fall at every step**)")
        + f", under load {series('pileup_at_load_m', '{:.1f}', 1e9)} nm; true contact radius "
        f"{series('true_contact_radius_m', '{:.0f}', 1e9)} nm, area ratio {series('area_ratio', '{:.3f}')}.",
        f"Load at {base['depth_m'] * 1e9:.0f} nm {series('p_max_n', '{:.4f}', 1e3)} mN ({rel('p_max_n')} % "
        f"from μ = {base['mu']}); loading curvature C {series('c_fit_pa', '{:.2f}', 1e-9)} GPa ({rel('c_fit_pa')} %); "
        f"residual depth {series('residual_depth_m', '{:.1f}', 1e9)} nm; impression "
        f"{series('impression_depth_m', '{:.1f}', 1e9)} nm deep at the axis.",
        f"Friction dissipation (μ > 0) {', '.join(f'{d * 1e12:.3g}' for d in diss)} pJ "
        + ("(grows with μ)" if grows else "(**does not grow at every step**)")
        + f"; particles sticking while the cone pushes at {base['push_depth_m'] * 1e9:.0f} nm "
        f"{series('sticking_at_push', '{:.0f}')} of {series('contacts_at_push', '{:.0f}')} (t/p "
        f"{series('tangential_over_normal_at_push', '{:+.3f}')}), after the hold "
        f"{series('sticking_at_unload', '{:.0f}')} of {series('contacts_at_unload', '{:.0f}')} (t/p "
        f"{series('tangential_over_normal', '{:+.3f}')}).",
    ]


def write_docs_cone(study, readme):
    r0 = study["runs"][0]
    out = [f"{CONE_BEGIN} (generated by scripts/friction_study.py --scene cone, `make friction-study-cone`; "
           "do not edit) -->",
           f"Generated by `make friction-study-cone{'' if study['ranks'] == 2 else ' NP=' + str(study['ranks'])}` "
           f"({study['date']}, commit {study['commit']}, {study['ranks']} "
           f"rank{'s' if study['ranks'] > 1 else ''}): `cone_indentation {' '.join(cone_args(study['levels']))} "
           f"--friction μ" + (f" --friction-max-iter {study['max_iter']}" if study["max_iter"] else "")
           + f"` ({r0['levels']} levels, finest cell {r0['finest_cell_m'] * 1e9:.1f} nm, {r0['particles']} "
           f"particles; the 70.3° cone to {r0['depth_m'] * 1e9:.0f} nm at 10 m/s, held, withdrawn at 0.5 m/s). "
           "Load: the whole body's at the final depth after the hold (the start of unloading). Pile-up: the top "
           "particle row's highest point after unloading. H, E_r: Oliver–Pharr's (contact depth, A = 24.5 h_c²) "
           "and with the true contact area π a² (a the outer edge of the outermost loaded face over the hold); "
           f"E_r against E/(1 − ν²) = {r0['input_reduced_modulus_pa'] / 1e9:.2f} GPa. t/p: the tangential force "
           "on the body along the flank's upward tangent over the normal force (negative: towards the tip), "
           "with the number of loaded contact particles that stick, at the end of the constant-speed push (the cone "
           "moving at 10 m/s) and at the start of unloading (after the hold, at rest). Dissipation: `gimlet_friction_stats`, the whole body's, at the end; in "
           "brackets the share of the work done by the start of unloading.",
           ""] + table_cone(study["runs"], study["ranks"]) + [""] + [f"- {c}" for c in study["findings"]] + [CONE_END]
    text = open(readme).read()
    i, j = text.find(CONE_BEGIN), text.find(CONE_END)
    if i < 0 or j < 0:
        sys.exit(f"friction_study: {readme} has no {CONE_BEGIN} ... {CONE_END} markers")
    with open(readme, "w") as f:
        f.write(text[:i] + "\n".join(out) + text[j + len(CONE_END):])


CONE_KEYS = ["mu", "p_max_n", "largest_load_n", "c_fit_pa", "pileup_m", "pileup_r_m", "pileup_at_load_m",
             "impression_depth_m", "residual_depth_m", "h_max_m", "contact_depth_m", "stiffness_n_per_m", "fit_m",
             "area_m2", "hardness_pa", "reduced_modulus_pa", "true_contact_radius_m", "true_area_m2",
             "true_hardness_pa", "true_reduced_modulus_pa", "area_ratio", "friction_dissipation_j",
             "friction_dissipation_at_push_j", "friction_dissipation_at_unload_j", "work_at_unload_j", "push_depth_m",
             "contacts_at_push", "sticking_at_push", "tangential_over_normal_at_push", "contacts_at_unload",
             "sticking_at_unload", "tangential_over_normal", "friction_solves", "friction_iterations", "friction_iterations_max",
             "kinetic_over_work", "levels", "finest_cell_m", "particles", "steps", "wall_s"]


def main_cone(o, mus, commit):
    exe = o.exe or os.path.join(o.build, "examples-c", "cone_indentation")
    print(f"friction study on {o.np} rank(s): J2 cone (70.3 deg, axisymmetric) to 300 nm and back, "
          f"{o.cone_levels or 'the proposed'} levels, mu = {', '.join(mus)}", flush=True)
    runs = [run_cone(exe, o.np, mu, o.out, o.max_iter, o.cone_levels, o.reuse) for mu in mus]
    print("\n".join(table_cone(runs, o.np)))
    study = {"date": datetime.date.today().isoformat(), "ranks": o.np, "runs": runs, "findings": findings_cone(runs),
             "max_iter": o.max_iter, "levels": o.cone_levels, "commit": commit}
    for c in study["findings"]:
        print("  " + c)
    os.makedirs(o.out, exist_ok=True)
    path = os.path.join(o.out, "friction_study_cone.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(CONE_KEYS)
        for r in runs:
            w.writerow([r[k] for k in CONE_KEYS])
    if not o.no_docs:
        write_docs_cone(study, os.path.join(ROOT, "README.md"))
        print("updated README.md (the cone's friction table)")
    print(f"wrote {path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", choices=["wedge", "cone"], default="wedge",
                    help="the J2 wedge (wedge_indentation, the default) or the axisymmetric cone (cone_indentation)")
    ap.add_argument("--np", type=int, default=2)
    ap.add_argument("--out", default="results")
    ap.add_argument("--build", default=os.environ.get("BUILD", "build"))
    ap.add_argument("--exe", help="the wedge_indentation (cone_indentation with --scene cone) executable "
                    "(default BUILD/examples-c/wedge_indentation or cone_indentation)")
    ap.add_argument("--mu", default="0,0.1,0.2,0.3", help="comma-separated friction coefficients (inf: adhesion)")
    ap.add_argument("--max-iter", type=int, default=0,
                    help="GIMLET_CONTACT_FRICTION_MAX_ITER of the runs (default: the library's, 200)")
    ap.add_argument("--cone-levels", type=int, default=3,
                    help="--scene cone: cone_indentation --levels L (default 3; 0: the example's own proposal, 4)")
    ap.add_argument("--no-docs", action="store_true")
    ap.add_argument("--reuse", action="store_true",
                    help="reuse a run whose output directory holds the same command's complete log (same build)")
    o = ap.parse_args()
    mus = [m.strip() for m in o.mu.split(",") if m.strip()]
    if o.scene == "cone":
        return main_cone(o, mus, logged_run.source_commit(ROOT))
    exe = o.exe or os.path.join(o.build, "examples-c", "wedge_indentation")
    print(f"friction study on {o.np} rank(s): J2 wedge to 600 nm and back, mu = {', '.join(mus)}", flush=True)
    runs = [run(exe, o.np, mu, o.out, o.max_iter, o.reuse) for mu in mus]
    t = table(runs)
    print("\n".join(t))
    study = {"date": datetime.date.today().isoformat(), "ranks": o.np, "runs": runs, "findings": findings(runs),
             "max_iter": o.max_iter}
    for c in study["findings"]:
        print("  " + c)
    study["commit"] = logged_run.source_commit(ROOT)
    os.makedirs(o.out, exist_ok=True)
    keys = ["mu", "load", "p_max", "pile_up_m", "pile_up_x_m", "impression_m", "h_residual_m", "a_op_m", "h_op_gpa",
            "er_op_gpa", "a_measured_m", "h_measured_gpa", "er_measured_gpa", "a_at_depth_m", "contacts_at_depth",
            "sticking_at_depth", "traction_outward", "tangential_force_n_per_m", "normal_force_n_per_m",
            "dissipation_j_per_m", "friction_solves", "friction_iterations", "friction_iterations_max", "steps",
            "wall_s"]
    path = os.path.join(o.out, "friction_study.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(keys)
        for r in runs:
            w.writerow([r[k] for k in keys])
    if not o.no_docs:
        write_docs(study, os.path.join(ROOT, "README.md"))
        print("updated README.md (the friction table)")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
