"""Interrupted runs: is what a signal leaves behind readable and consistent?

Starts `mpiexec -n RANKS python -m app run CONFIG` several times, sends SIGINT or SIGTERM
to mpiexec after a random delay, and checks the output folder: summary.json parses and
says `interrupted` or `completed` (a signal after the end), its `steps` are exactly the
step_NNNN.h5 files present, numbered 1..k without gaps; both XDMF files are well-formed
XML listing exactly those steps; every dataset of every step file reads with h5py, through
its links to an earlier step's copy; no `.tmp` file is left.
With `--paraview`, each folder is also opened with ParaView (scripts/check_xdmf.py under
pvpython). One JSON line per trial; exit 1 if any trial has a problem. No CONFIG (without
`--audit`), a CONFIG that does not exist, or (without `--max-delay`) an unsignalled run
that does not complete, e.g. an unknown option passed on, stops with `error:`, exit 2.

    .venv/bin/python scripts/check_interrupts.py configs/cattaneo.toml --trials 6 --paraview
    .venv/bin/python scripts/check_interrupts.py configs/hertz.toml --earlier --max-delay 1.5
    .venv/bin/python scripts/check_interrupts.py --audit OUT [OUT ...]   # folders only

`--sweep KEY=V1,V2` runs `study CONFIG --sweep ...` instead, `--delays 1.0,1.5 --repeat 10`
signals at those seconds (SIGINT unless `--signal`), and each trial is judged as a whole:
`completed` (exit 0, every output there), `interrupted` (an `error: interrupted ...` line;
exit 130 / 143, or mpiexec's 1 on several ranks) or `silent` (no line, exit not 0: a
problem). The counts per delay close the output:

    .venv/bin/python scripts/check_interrupts.py configs/hertz.toml --ranks 2 \
        --sweep interface.contact.mu=0.0,0.1 --delays 1.0,1.5,2.0 --repeat 10

A stopped run's sweep must give its account (the `sweep:` line, and once a run completed
a sweep.csv row for every run); `in_c` counts the trials stopped inside a MUMPS call
(app/_hard_stop.c wrote the study's summary). Options the script does not know go to the
study (e.g. `--mesh-size 0.5`).
"""

from __future__ import annotations

import argparse
import csv
import json
import random
import re
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from app_runner import ENV  # noqa: E402

sys.path.insert(0, str(ROOT))  # this checkout's app, not another one installed in .venv
from app.output.read import step_datasets  # noqa: E402


def step_numbers(out: Path) -> list[int]:
    return sorted(int(p.stem[5:]) for p in out.glob("step_*.h5")
                  if re.fullmatch(r"step_\d{4,}\.h5", p.name))


def xdmf_times(path: Path) -> list[float] | str:
    try:
        return [float(t.get("Value")) for t in ET.parse(path).getroot().iter("Time")]
    except (ET.ParseError, OSError) as exc:
        return f"{type(exc).__name__}: {exc}"


def meshio_problems(out: Path, steps: list[int]) -> list[str]:
    """Read both XDMF files with meshio's TimeSeriesReader: the steps' times, and the
    README's arrays with their shapes at every step."""
    import meshio

    problems = []
    for name in ("results.xdmf", "contact.xdmf"):
        if not (out / name).exists() or not steps:
            continue
        try:
            with meshio.xdmf.TimeSeriesReader(out / name) as r:
                points, _ = r.read_points_cells()
                times = []
                for k in range(r.num_steps):
                    t, pd, cd = r.read_data(k)
                    times.append(t)
                    want = ({"displacement": 3} if name == "results.xdmf"
                            else {"displacement": 3, "normal": 3, "tangent": 3, "p": 1})
                    for arr, comps in want.items():
                        got = pd.get(arr)
                        if got is None or got.shape != ((len(points),) if comps == 1
                                                         else (len(points), comps)):
                            problems.append(f"meshio {name} t={t}: {arr} "
                                            f"{None if got is None else got.shape}")
                    if name == "results.xdmf":
                        stress = cd.get("stress", [None])[0]
                        if stress is None or stress.shape[1] != 4:
                            problems.append(f"meshio {name} t={t}: stress")
        except Exception as exc:  # any failure to read is the finding
            problems.append(f"meshio {name}: {type(exc).__name__}: {exc}")
            continue
        if times != [float(k) for k in steps]:
            problems.append(f"meshio {name} times {times} vs steps {steps}")
    return problems


def audit(out: Path, config: Path | None = None) -> tuple[dict, list[str]]:
    """(facts, problems) of an output folder left by a stopped run (of `config`: the
    summary must be that run's, not an earlier run's in the same folder)."""
    problems: list[str] = []
    steps = step_numbers(out)
    facts: dict = {"step_files": steps}
    if steps != list(range(1, len(steps) + 1)):
        problems.append(f"step files not 1..k: {steps}")
    try:
        s = json.loads((out / "summary.json").read_text())
    except (OSError, json.JSONDecodeError) as exc:
        return facts, problems + [f"summary.json: {type(exc).__name__}: {exc}"]
    facts.update(status=s.get("status"), error=s.get("error"))
    if config is not None and s.get("config") != str(config):
        problems.append(f"summary.json is of {s.get('config')}, not of this run")
    listed = [st["step"] for st in s.get("steps", [])]
    if listed != steps:
        problems.append(f"summary steps {listed} vs step files {steps}")
    if s.get("status") not in ("interrupted", "completed"):
        problems.append(f"status {s.get('status')!r}")
    for name in ("results.xdmf", "contact.xdmf"):
        if not (out / name).exists():
            if steps and name == "results.xdmf":
                problems.append(f"{name} missing")
            continue
        t = xdmf_times(out / name)
        if t != [float(k) for k in steps]:
            problems.append(f"{name} times {t} vs step files {steps}")
    for k in steps:
        try:
            step_datasets(out / f"step_{k:04d}.h5")  # each dataset, through its links
        except (OSError, KeyError) as exc:
            problems.append(f"step_{k:04d}.h5: {exc}")
    problems += meshio_problems(out, steps)
    left = sorted(p.name for p in out.glob("*.tmp"))
    if left:
        problems.append(f"temporary files left: {left}")
    return facts, problems


def sweep_audit(out: Path, config: Path, n_runs: int) -> tuple[dict, list[str]]:
    """(facts, problems) of a sweep's folder: each run's folder as `audit`, sweep.csv's rows
    and statuses, the plots; `in_c`: the study's summary is the one app/_hard_stop.c writes
    (a signal inside a MUMPS call: it has no end_time)."""
    facts: dict = {"runs": {}, "rows": None, "plots": len(list(out.glob("sweep_*.png")))}
    problems: list[str] = []
    for k in range(n_runs):
        run_dir = out / f"run_{k:03d}"
        if not run_dir.is_dir():
            continue
        if {x.name for x in run_dir.iterdir()} <= {".lock"}:  # stopped as it took OUT
            facts["runs"][run_dir.name] = "not started"
            continue
        f, p = audit(run_dir, config)
        facts["runs"][run_dir.name] = f.get("status")
        problems += [f"{run_dir.name}: {x}" for x in p]
    try:  # (the start-up handler's summary has none either, but no run was stopped)
        study = json.loads((out / "summary.json").read_text())
        facts["in_c"] = (study.get("status") == "interrupted" and "end_time" not in study
                         and "interrupted" in facts["runs"].values())
    except (OSError, ValueError):
        pass
    if (out / "sweep.csv").exists():
        with open(out / "sweep.csv", newline="") as fh:
            rows = list(csv.DictReader(fh))
        facts["rows"] = len(rows)
        # (an interrupted sweep lists the run it stopped and those it never started)
        odd = {r.get("status") for r in rows} - {"completed", "failed", "interrupted",
                                                  "not run"}
        if odd:
            problems.append(f"sweep.csv: rows of status {sorted(map(str, odd))}")
        facts["row_statuses"] = [r.get("status") for r in rows]
    return facts, problems


def sweep_outcome_problems(facts: dict, lines: list[str], n_runs: int) -> list[str]:
    """A stopped run's sweep gives its account as on the Python path (one interface per
    run, as the scenes used here): the `sweep:` line, and once a run completed, a row in
    sweep.csv for every run (before, the C handler's stop inside a MUMPS call left both
    out)."""
    statuses = list(facts["runs"].values())
    if "interrupted" not in statuses:
        return []
    problems = [] if any(x.startswith("sweep:") for x in lines) else [
        "a run interrupted, but no `sweep:` line"]
    if "completed" in statuses and facts["rows"] != n_runs:
        problems.append(f"sweep.csv: {facts['rows']} rows for {n_runs} runs")
    return problems


MPIEXEC_TERM_DELAY = 1.0
"""Seconds from a Ctrl-C to the SIGTERM Open MPI's mpiexec sends the ranks (the first
signal they see; README "Parallel consistency and readable output")."""


def verdict(code: int, ranks: int, line: str | None, complete: bool,
            after: float = float("inf")) -> str:
    """completed / interrupted / silent (see the module). after: seconds from the signal
    to mpiexec's end; a job that ended, complete, before mpiexec passed the signal on gets
    mpiexec's own exit 1 with no line (no rank was signalled): completed."""
    if code == 0:
        return "completed" if complete else "silent"
    if (ranks > 1 and code == 1 and line is None and complete
            and after < MPIEXEC_TERM_DELAY):
        return "completed"
    codes = (130, 143) if ranks == 1 else (1, 130, 143)
    if line and line.startswith("error: interrupted") and code in codes:
        return "interrupted"
    return "silent"


def signal_and_wait(proc: subprocess.Popen, delay: float, sig: signal.Signals) -> str | None:
    """Send sig to proc after delay seconds and wait for it: its stderr, or None if it
    hung (killed after 120 s)."""
    time.sleep(delay)
    proc.send_signal(sig)
    try:
        return proc.communicate(timeout=120)[1]
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        return None


def sweep_trial(config: Path, ranks: int, delay: float, sig: signal.Signals, out: Path,
                sweep: str, log: bool = True, extra: tuple[str, ...] = ()) -> dict:
    """`study CONFIG --sweep SWEEP [EXTRA]` stopped by `sig` after `delay` s; with several
    ranks each rank's stderr goes to OUT_log (mpiexec --output-filename)."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-m", "app", "study", str(config), "--sweep", sweep, "--out",
           str(out), *extra]
    if ranks > 1:
        logs = out.with_name(out.name + "_log")
        shutil.rmtree(logs, ignore_errors=True)
        cmd = [shutil.which("mpiexec") or "mpiexec", "--oversubscribe", "-n", str(ranks),
               *(["--output-filename", str(logs)] if log else []), *cmd]
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=ROOT, env=dict(ENV, PYTHONPATH=str(ROOT)),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    err = signal_and_wait(proc, delay, sig)
    if err is None:
        return {"delay": delay, "signal": sig.name, "verdict": "hung", "problems": ["hung"]}
    n_runs = len(sweep.partition("=")[2].split(","))
    facts, problems = sweep_audit(out, config, n_runs)
    lines = [x for x in err.splitlines() if x.startswith(("error:", "sweep:"))
             or "rows ->" in x]
    line = next((x for x in reversed(lines) if x.startswith("error:")), None)
    complete = (len(facts["runs"]) == n_runs and facts["plots"] > 0 and
                set(facts["runs"].values()) == {"completed"})
    v = verdict(proc.returncode, ranks, line, complete, time.monotonic() - t0 - delay)
    if v == "silent":
        problems.append("a nonzero exit with no line" if proc.returncode else "incomplete")
    problems += sweep_outcome_problems(facts, lines, n_runs)
    return {"delay": round(delay, 2), "signal": sig.name, "exit": proc.returncode,
            "seconds": round(time.monotonic() - t0, 2), "verdict": v, **facts,
            "lines": lines[-3:], "problems": problems}


def trial(config: Path, ranks: int, delay: float, sig: signal.Signals, out: Path,
          extra: list[str], earlier: bool = False) -> dict:
    """One run stopped by `sig` after `delay` seconds (seconds after mpiexec starts);
    earlier: into a folder holding a completed run of configs/patch.toml."""
    shutil.rmtree(out, ignore_errors=True)
    if earlier:
        subprocess.run([sys.executable, "-m", "app", "run", str(ROOT / "configs" / "patch.toml"),
                        "--out", str(out), "--quiet"], cwd=ROOT,
                       env=dict(ENV, PYTHONPATH=str(ROOT)), capture_output=True, check=True)
    cmd = [sys.executable, "-m", "app", "run", str(config), "--out", str(out), *extra]
    if ranks > 1:
        cmd = [shutil.which("mpiexec") or "mpiexec", "--oversubscribe", "-n", str(ranks), *cmd]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=dict(ENV, PYTHONPATH=str(ROOT)),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    err = signal_and_wait(proc, delay, sig)
    if err is None:
        return {"delay": delay, "signal": sig.name, "problems": ["hung after the signal"]}
    facts, problems = audit(out, config)
    line = [x for x in err.splitlines() if x.startswith("error:")]
    return {"delay": round(delay, 2), "signal": sig.name, "exit": proc.returncode, **facts,
            "line": line[-1] if line else None, "problems": problems}


def _check_config(ap: argparse.ArgumentParser, config: Path | None) -> None:
    """A run needs a CONFIG that exists (as the runs see it, from the project folder):
    before, a missing one was signalled during start-up and read as a clean trial."""
    if config is None:
        ap.error("give a CONFIG to run (or --audit OUT ... to check existing folders)")
    if not (ROOT / config).is_file():
        ap.error(f"config file '{config}' does not exist")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config", type=Path, nargs="?")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--trials", type=int, default=6)
    ap.add_argument("--max-delay", type=float, help="seconds (default: one full run's time)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("/tmp/check_interrupts"))
    ap.add_argument("--paraview", action="store_true", help="also open each folder in ParaView")
    ap.add_argument("--earlier", action="store_true",
                    help="run into a folder that holds an earlier, completed run")
    ap.add_argument("--audit", type=Path, nargs="+",
                    help="only check these existing output folders (no runs)")
    ap.add_argument("--sweep", help="KEY=V1,V2,...: signal `study CONFIG --sweep` instead")
    ap.add_argument("--delays", help="with --sweep: comma list of seconds")
    ap.add_argument("--repeat", type=int, default=10, help="with --delays: trials each")
    ap.add_argument("--signal", default="SIGINT", choices=("SIGINT", "SIGTERM"))
    a, extra = ap.parse_known_args()
    if not a.audit:
        _check_config(ap, a.config)
    if a.sweep:
        sys.exit(sweep_trials(a, extra))
    if a.audit:
        bad = 0
        for out in a.audit:
            facts, problems = audit(out)
            bad += bool(problems)
            print(json.dumps({"out": str(out), **facts, "problems": problems}), flush=True)
        sys.exit(1 if bad else 0)
    rng = random.Random(a.seed)
    if a.max_delay is None:
        t0 = time.monotonic()
        full = trial(a.config, a.ranks, 0.0, signal.SIGCONT, a.out / "full", extra)
        a.max_delay = time.monotonic() - t0
        if full.get("status") != "completed":  # signals into a failing run test nothing
            ap.error(f"the unsignalled run of {a.config} that times the trials ended "
                     f"{full.get('status')!r} ({full.get('error')}): fix the config or "
                     f"options (its output: {a.out / 'full'})")
    bad = 0
    for i in range(a.trials):
        sig = (signal.SIGINT, signal.SIGTERM)[i % 2]
        out = a.out / f"trial_{i}"
        row = trial(a.config, a.ranks, rng.uniform(0.3, a.max_delay), sig, out, extra,
                    a.earlier)
        if a.paraview and not row["problems"] and row.get("step_files"):
            pv = subprocess.run([shutil.which("pvpython") or "pvpython",
                                 str(ROOT / "scripts" / "check_xdmf.py"), str(out)],
                                capture_output=True, text=True)
            row["paraview"] = "ok" if pv.returncode == 0 else pv.stdout[-600:]
            if pv.returncode != 0:
                row["problems"].append("ParaView check failed")
        row.update(config=str(a.config), trial=i, out=str(out))
        bad += bool(row["problems"])
        print(json.dumps(row), flush=True)
    sys.exit(1 if bad else 0)


def sweep_trials(a, extra: list[str]) -> int:
    """--sweep: the trials over --delays (or --trials random delays), with counts; extra:
    the study's further options (e.g. --mesh-size)."""
    rng = random.Random(a.seed)
    delays = ([float(x) for x in a.delays.split(",") for _ in range(a.repeat)] if a.delays
              else [rng.uniform(0.3, a.max_delay or 3.0) for _ in range(a.trials)])
    counts: dict[float, dict[str, int]] = {}
    bad = 0
    for i, d in enumerate(delays):
        row = sweep_trial(a.config, a.ranks, d, signal.Signals[a.signal], a.out / f"t{i}",
                          a.sweep, extra=tuple(extra))
        counts.setdefault(round(d, 2), {}).setdefault(row["verdict"], 0)
        counts[round(d, 2)][row["verdict"]] += 1
        if row.get("in_c"):  # (stopped inside a MUMPS call: the C handler's account)
            counts[round(d, 2)]["in_c"] = counts[round(d, 2)].get("in_c", 0) + 1
        bad += bool(row["problems"])
        print(json.dumps({"trial": i, **row}), flush=True)
    print(json.dumps({"counts": {str(k): v for k, v in counts.items()}}), flush=True)
    return 1 if bad else 0


if __name__ == "__main__":
    main()
