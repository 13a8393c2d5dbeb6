"""Hook scripts for the signal tests: `python -c SCRIPT ARG...` replaces one function of the
app, then runs the CLI on ARG... (app.cli.main), so that a test can stop or signal a run at
a chosen place; and the subprocesses that run them."""

from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap

from support import ROOT, mpi_env


def cli_with(patch: str) -> str:
    """A `python -c` script: `patch` (Python that replaces a function; `sys` is imported),
    then the CLI on the script's arguments, its exit status the script's."""
    return ("import sys\n" + textwrap.dedent(patch).strip() + "\n"
            "from app.cli import main\nsys.exit(main(sys.argv[1:]))\n")


def stop_in_run(n: int, module: str = "app.studies.convergence") -> str:
    """Ctrl-C (KeyboardInterrupt) inside the n-th run of a study (module
    `app.studies.convergence`) or a sweep (`app.studies.sweep`): their `run` raises it on
    its n-th call."""
    return cli_with(f"""
        import {module}
        real = {module}.run
        calls = []

        def run(cfg, opts):
            calls.append(opts)
            if len(calls) == {n}:
                raise KeyboardInterrupt  # Ctrl-C inside run {n}
            return real(cfg, opts)

        {module}.run = run
        """)


def announce_and_sleep(target: str, word: str, seconds: float, then_call: bool = True) -> str:
    """`target` ("module.function") prints `word` on stdout, sleeps `seconds` in Python
    (where a signal's handler runs), then calls the real function (`then_call`) or
    returns None."""
    module, name = target.rsplit(".", 1)
    return cli_with(f"""
        import time
        import {module}
        real = {module}.{name}

        def hooked(*args, **kwargs):
            print({word!r}, flush=True)
            time.sleep({seconds!r})
            return real(*args, **kwargs) if {then_call!r} else None

        {module}.{name} = hooked
        """)


def sleep_in_a_solve(when: str = "True") -> str:
    """`LinearSolver.solve`, when `when` holds (a Python expression; `out` is the --out
    folder), prints "ready" and sleeps 60 s in one C call that keeps the GIL (as a long
    PETSc call does) inside `hard_stop.armed()`, then solves."""
    return cli_with(f"""
        import ctypes
        from pathlib import Path
        from app import hard_stop
        from app.assembly import solve
        real = solve.LinearSolver.solve
        out = Path(sys.argv[sys.argv.index("--out") + 1])

        def solve_(self, b, x=None, **kw):
            if {when}:
                with hard_stop.armed():
                    print("ready", flush=True)
                    ctypes.PyDLL(None).sleep(60)
            return real(self, b, x, **kw)

        solve.LinearSolver.solve = solve_
        """)


def run_script(script: str, args: list[str], timeout: float = 300
               ) -> subprocess.CompletedProcess:
    """`python -c script ARGS` on one rank, to its end (stdout and stderr captured)."""
    return subprocess.run([sys.executable, "-c", script, *args], cwd=ROOT, env=mpi_env(),
                          capture_output=True, text=True, timeout=timeout)


def start_script(script: str, args: list[str], ranks: int = 1) -> subprocess.Popen:
    """`python -c script ARGS` started, under `mpiexec -n ranks` for ranks > 1 (stdout and
    stderr piped, text)."""
    cmd = [sys.executable, "-c", script, *args]
    if ranks > 1:
        cmd = [shutil.which("mpiexec"), "-n", str(ranks), *cmd]
    return subprocess.Popen(cmd, cwd=ROOT, env=mpi_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def signal_after(word: str, script: str, args: list[str], sig: int, ranks: int = 1,
                 timeout: float = 60) -> subprocess.CompletedProcess:
    """`start_script`, then once its first stdout line is `word`, `sig` to it (to mpiexec
    for ranks > 1); waits for its end (stdout: what followed the word's line)."""
    proc = start_script(script, args, ranks)
    line = proc.stdout.readline()
    assert line.strip() == word, line
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=timeout)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
