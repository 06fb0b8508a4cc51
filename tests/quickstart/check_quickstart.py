#!/usr/bin/env python3
"""Checks of the README's quickstart (examples-c/quickstart.c).

  check_quickstart.py readme README.md examples-c/quickstart.c
      The README shows the file verbatim: it holds a ```c block whose text is
      exactly the file's, so the code a reader copies is the code ctest runs.

  check_quickstart.py run MPIEXEC NUMPROC_FLAG EXE
      Runs EXE on 1 and on 2 ranks. Each run prints one line
          depth D m, load P N/m, uniaxial strain Q N/m
      where P is the punch's load and Q the closed form of a block in uniaxial
      strain, M D W / H (M the P-wave modulus E (1 - nu) / ((1 + nu)(1 - 2 nu)),
      W = H = 1 m). Checks: D > 0; P > 0 and within TOLERANCE of Q; the 2-rank
      line equal to the 1-rank line (results do not depend on the number of
      ranks). The bound: the block is compressed by 0.5 %, so the finite
      strain alone puts P 0.25 % above the small-strain Q (ln(1/(1 - 0.005))
      over 0.005), and the punch is moved slowly (speed ramps of 0.05 s, about
      3 periods of the block's fundamental mode), so what the inertia and the
      ringing add is a few tenths of a per cent more.
"""
import re
import subprocess
import sys

TOLERANCE = 0.01
LINE = re.compile(r"^depth (\S+) m, load (\S+) N/m, uniaxial strain (\S+) N/m$", re.M)


def fail(msg):
    print(f"FAIL: {msg}")
    sys.exit(1)


def readme(readme_path, source_path):
    with open(readme_path, encoding="utf-8") as f:
        text = f.read()
    with open(source_path, encoding="utf-8") as f:
        src = f.read()
    if "```c\n" + src + "```\n" not in text:
        fail(f"{readme_path} has no ```c block equal to {source_path}: paste the file into the "
             "quickstart section again (the block must be the file, byte for byte)")
    print(f"{readme_path} shows {source_path} verbatim ({src.count(chr(10))} lines)")


def run_once(mpiexec, flag, exe, n):
    p = subprocess.run([mpiexec, flag, str(n), exe], capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        fail(f"{exe} on {n} rank(s) exited with {p.returncode}\n{p.stdout}\n{p.stderr}")
    lines = LINE.findall(p.stdout)
    if len(lines) != 1:
        fail(f"{exe} on {n} rank(s) printed {len(lines)} result lines, expected 1:\n{p.stdout}")
    print(f"{n} rank(s): {LINE.search(p.stdout).group(0)}")
    return lines[0]


def run(mpiexec, flag, exe):
    one = run_once(mpiexec, flag, exe, 1)
    depth, load, closed = (float(x) for x in one)
    if not depth > 0:
        fail(f"depth {depth} must be > 0")
    if not (load > 0 and closed > 0):
        fail(f"load {load} and closed form {closed} must be > 0")
    rel = load / closed - 1
    print(f"load / closed form - 1 = {rel:+.3%} (bound {TOLERANCE:.0%})")
    if abs(rel) > TOLERANCE:
        fail(f"load {load} N/m is {rel:+.2%} from the uniaxial-strain closed form {closed} N/m")
    two = run_once(mpiexec, flag, exe, 2)
    if two != one:
        fail(f"2 ranks printed {two}, 1 rank {one}: results must not depend on the rank count")
    print("2 ranks: the same line as 1 rank")


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "readme":
        readme(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 5 and sys.argv[1] == "run":
        run(*sys.argv[2:])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
