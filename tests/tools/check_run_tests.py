#!/usr/bin/env python3
"""ctest scripts/RunTestsCountsWhatRan: scripts/run_tests.sh passes only when every test the
selection lists ran and passed. It runs the script on small generated ctest folders (never on the
build that runs this test): all pass -> 0; no test selected (-R nomatch) -> non-zero; fewer tests
ran than `ctest -N` lists (a ctest that stops early, simulated by a wrapper on PATH) -> non-zero;
a failing test -> non-zero."""
import argparse
import os
import shutil
import stat
import subprocess
import sys

FAILURES = []


def expect(cond, what, detail=""):
    print(("ok      " if cond else "FAILED  ") + what)
    if not cond:
        FAILURES.append(what)
        if detail:
            print("        " + detail.replace("\n", "\n        "))


def make_build(folder, tests):
    """A folder ctest reads as a build: one add_test per (name, command)."""
    os.makedirs(folder)
    with open(os.path.join(folder, "CTestTestfile.cmake"), "w") as f:
        for name, command in tests:
            f.write("add_test(%s %s)\n" % (name, command))


def run(script, args, env=None):
    p = subprocess.run(["bash", script] + args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       text=True, env=env, timeout=120)
    return p.returncode, p.stdout


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--script", required=True)
    ap.add_argument("--tmp", required=True)
    a = ap.parse_args()
    shutil.rmtree(a.tmp, ignore_errors=True)
    os.makedirs(a.tmp)
    true_cmd = shutil.which("true")
    false_cmd = shutil.which("false")
    env = dict(os.environ, DYGSLAM_ALLOW_SKIPS="0", JOBS="1")

    passing = os.path.join(a.tmp, "passing")
    make_build(passing, [("first", true_cmd), ("second", true_cmd), ("third", true_cmd)])
    code, out = run(a.script, [passing], env)
    expect(code == 0, "three passing tests: exit 0 (%d)" % code, out)
    expect("3 of 3 listed tests ran" in out, "summary says 3 of 3 listed tests ran", out)

    code, out = run(a.script, [passing, "-R", "nomatch"], env)
    expect(code != 0, "-R nomatch: no test ran, exit non-zero (%d)" % code, out)
    expect("no test ran" in out, "-R nomatch: the summary says no test ran", out)

    code, out = run(a.script, [passing, "-R", "second"], env)
    expect(code == 0, "-R second: 1 of 1 listed ran, exit 0 (%d)" % code, out)

    # A ctest that lists three tests but runs only the first (as one that crashes or stops early).
    wrapper_dir = os.path.join(a.tmp, "bin")
    os.makedirs(wrapper_dir)
    wrapper = os.path.join(wrapper_dir, "ctest")
    with open(wrapper, "w") as f:
        f.write('#!/bin/bash\nfor x in "$@"; do [[ $x == -N ]] && exec %s "$@"; done\n'
                'exec %s "$@" -R first\n' % (shutil.which("ctest"), shutil.which("ctest")))
    os.chmod(wrapper, os.stat(wrapper).st_mode | stat.S_IXUSR)
    short_env = dict(env, PATH=wrapper_dir + os.pathsep + env.get("PATH", ""))
    code, out = run(a.script, [passing], short_env)
    expect(code != 0, "1 of 3 listed tests ran: exit non-zero (%d)" % code, out)
    expect("1 tests ran but ctest -N lists 3" in out, "the summary names both counts", out)

    failing = os.path.join(a.tmp, "failing")
    make_build(failing, [("good", true_cmd), ("bad", false_cmd)])
    code, out = run(a.script, [failing], env)
    expect(code != 0, "a failing test: exit non-zero (%d)" % code, out)
    expect("failed: bad" in out, "the failing test is named", out)

    code, out = run(a.script, [os.path.join(a.tmp, "no_such_build")], env)
    expect(code != 0, "a folder without tests: exit non-zero (%d)" % code, out)

    print("%d failures" % len(FAILURES))
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
