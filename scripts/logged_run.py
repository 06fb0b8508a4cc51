"""Run a study's command once and keep its output (shared by
scripts/wedge_study.py and scripts/friction_study.py)."""
import os
import subprocess
import sys


def run_logged(cmd, d, what, reuse, tool):
    """Runs `cmd`, keeping its output in `d`/log.txt and the command in
    `d`/command.txt once it succeeded; with `reuse`, a directory holding the
    same command's complete log gives that log instead of a run. A failed
    run ends the program with a message naming `tool` and `what`. Returns
    the standard output."""
    log, done = os.path.join(d, "log.txt"), os.path.join(d, "command.txt")
    if reuse and os.path.exists(done) and open(done).read() == " ".join(cmd) + "\n":
        return open(log).read()
    p = subprocess.run(cmd, capture_output=True, text=True)
    with open(log, "w") as f:
        f.write(p.stdout + p.stderr)
    if p.returncode != 0:
        sys.exit(f"{tool}: {what} failed ({' '.join(cmd)}):\n{p.stdout}{p.stderr}")
    with open(done, "w") as f:
        f.write(" ".join(cmd) + "\n")
    return p.stdout


def source_commit(root):
    """The checkout's commit, with " + local changes" when the sources
    (src, examples-c, crates) differ from it: what a study's figures are
    of."""
    git = subprocess.run(["git", "-C", root, "rev-parse", "--short=10", "HEAD"], capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", root, "diff", "--quiet", "HEAD", "--", "src", "examples-c",
                            "crates"]).returncode
    return (git.stdout.strip() or "unknown") + (" + local changes" if dirty else "")
