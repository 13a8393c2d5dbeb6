"""Interrupted runs: is what a signal leaves behind readable and consistent?

Starts `mpiexec -n RANKS python -m app run CONFIG` several times, sends SIGINT or SIGTERM
to mpiexec after a random delay, and checks the output folder: summary.json parses and
says `interrupted` or `completed` (a signal after the end), its `steps` are exactly the
step_NNNN.h5 files present, numbered 1..k without gaps; both XDMF files are well-formed
XML listing exactly those steps; every step file opens with h5py; no `.tmp` file is left.
With `--paraview`, each folder is also opened with ParaView (scripts/check_xdmf.py under
pvpython). One JSON line per trial; exit 1 if any trial has a problem.

    .venv/bin/python scripts/check_interrupts.py configs/cattaneo.toml --trials 6 --paraview
    .venv/bin/python scripts/check_interrupts.py configs/hertz.toml --earlier --max-delay 1.5
    .venv/bin/python scripts/check_interrupts.py --audit OUT [OUT ...]   # folders only
"""

from __future__ import annotations

import argparse
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

import h5py

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from app_runner import ENV  # noqa: E402


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
            with h5py.File(out / f"step_{k:04d}.h5", "r") as f:
                f["displacement"][()]
        except (OSError, KeyError) as exc:
            problems.append(f"step_{k:04d}.h5: {exc}")
    problems += meshio_problems(out, steps)
    left = sorted(p.name for p in out.glob("*.tmp"))
    if left:
        problems.append(f"temporary files left: {left}")
    return facts, problems


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
    time.sleep(delay)
    proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        return {"delay": delay, "signal": sig.name, "problems": ["hung after the signal"]}
    facts, problems = audit(out, config)
    line = [x for x in err.splitlines() if x.startswith("error:")]
    return {"delay": round(delay, 2), "signal": sig.name, "exit": proc.returncode, **facts,
            "line": line[-1] if line else None, "problems": problems}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
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
    a, extra = ap.parse_known_args()
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
        trial(a.config, a.ranks, 0.0, signal.SIGCONT, a.out / "full", extra)
        a.max_delay = time.monotonic() - t0
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


if __name__ == "__main__":
    main()
