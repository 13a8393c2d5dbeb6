"""Parallel consistency: does a scene give the same results on 1, 2, 3, ... ranks?

Runs each scene with `python -m app run` on every rank count (under `mpiexec
--oversubscribe` for more than one rank) and compares each multi-rank run with the 1-rank
run: every number of summary.json (energies, contact figures, reference errors, reactions,
rigid motion, balance, step statuses; not timings, memory or provenance) and every dataset
of mesh.h5 and each step_NNNN.h5 (displacements, stresses, `/contact`), and the list of
steps in results.xdmf / contact.xdmf. One JSON line per (scene, variant, ranks):

    {"config": ..., "args": [...], "ranks": 2, "status": ["completed", "completed"],
     "max_rel_diff": {"summary": .., "displacement": .., "stress": .., "contact": ..},
     "worst": [field, rel. diff], "mismatches": [...],
     "verdict": "ok" | "DIFFERENT" | "FAILED ALIKE"}

Runs that agree but did not complete read "FAILED ALIKE" with their `error` (exit 1):
nothing but the failure was compared. A scene that stops on purpose (EXPECTED_FAILURES:
hourglass_1sd) reads ok with `expected_failure`, its error.

A number's relative difference is |a - b| / (the largest |value| of its field over all
steps, pairs, nodes): round-off near a zero crossing is judged against the field's size.
Integers, strings and array shapes must be equal (`mismatches`). Round-off figures whose
size is round-off itself (KKT violations, LCP residual, balance residuals, mismatches)
are only required to stay below `--roundoff` (default 1e-7) on both runs.

    .venv/bin/python scripts/check_ranks.py                       # every shipped scene
    .venv/bin/python scripts/check_ranks.py configs/hertz.toml --ranks 1 2 --variants bulk
    .venv/bin/python scripts/check_ranks.py configs/hertz.toml --ranks 1 3 4 --mesh-size 2.0 \
        --command study --sweep interface.contact.mu=0.0,0.3     # a study: tables and runs
    .venv/bin/python scripts/check_ranks.py --compare OUT_1 OUT_4  # two folders that exist
    .venv/bin/python scripts/check_ranks.py --compare TREE_A TREE_B  # every output below

A job must also end alike on every rank count: the same exit status, no traceback, one
`error:` line when it fails, and no hang (`--timeout` seconds, then mpiexec's process group
is killed and the row says so). Text that names the run's output folder (an error's `steps
1..k are written in OUT`) is compared with the folder's name replaced by OUT.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from app_runner import ENV  # noqa: E402

sys.path.insert(0, str(ROOT))  # this checkout's app, not another one installed in .venv
from app.output.read import step_datasets  # noqa: E402

# summary keys that are not results (wall times, memory, where it ran)
VOLATILE = {"provenance", "timings", "peak_memory_mb", "step_seconds", "elapsed_seconds",
            "lcp_seconds", "assembly_rate_elements_per_s", "ranks", "energy_bracket",
            "end_time"}
# columns of a study's or sweep's CSV that are wall times or the rank count
CSV_VOLATILE = re.compile(r"^(t_.*|ranks|.*seconds.*)$")
# a study's CSV tables; every subfolder with a summary.json is one of its runs
STUDY_CSV = ("study.csv", "sweep.csv", "sweep_steps.csv", "richardson.csv")
# figures that are round-off by nature: compared against --roundoff, not with each other
ROUNDOFF = re.compile(r"(^|/)(kkt|kkt_pairs|lcp_residual|lcp_displacement_mismatch|residual|"
                      r"relative_residual|max_relative_residual)(/|$)")
# per-step counters that may differ with round-off without the result differing
SOLVER_PATH = re.compile(r"(^|/)(lemke_pivots|consistency_refinements|lcp_solves)$")
# a field below this fraction of its family's largest value is round-off in that family
FAMILY_ROUNDOFF = 1e-7
# cheap defaults for the slowest scenes (`--full` drops them)
CHEAP = {"cattaneo_many": ["--mesh-size", "1.0"]}
# step-file datasets judged against a family when their own values are round-off (a
# patch test's s_xy, the gap of closed pairs, q of frictionless pairs)
H5_FAMILY = {
    "stress": ("stress", "s_xx", "s_yy", "s_xy", "s_zz", "von_mises"),
    "length": ("displacement", "contact/gap", "contact/tau", "contact/tau_prev", "contact/slip",
               "contact/slip_increment", "contact/displacement"),
    "traction": ("contact/p", "contact/q"),
    "force": ("contact/p_force", "contact/q_force", "contact/a_force", "contact/c_force"),
}
# scenes that stop on purpose (their configs say so), with words their error must contain:
# failing alike on every rank count is their expected answer
EXPECTED_FAILURES = {"hourglass_1sd": "hourglass"}
BULK_VARIANTS = [["--sd", s] for s in ("1", "2", "3", "4", "8", "16")] + [
    ["--method", "fem-q4"]]


def run(config: Path, args: list[str], ranks: int, out: Path,
        timeout: float, command: str = "run") -> subprocess.CompletedProcess:
    """`python -m app COMMAND CONFIG --out OUT ARGS` on `ranks` ranks (run or study)."""
    cmd = [sys.executable, "-m", "app", command, str(config), "--out", str(out), "--quiet",
           *args]
    if ranks > 1:
        cmd = [shutil.which("mpiexec") or "mpiexec", "--oversubscribe", "-n", str(ranks), *cmd]
    env = dict(ENV, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:  # a hang: end mpiexec and its ranks (its own group)
        os.killpg(proc.pid, signal.SIGKILL)
        stdout, stderr = proc.communicate()
        return subprocess.CompletedProcess(cmd, None, stdout, stderr)
    return subprocess.CompletedProcess(cmd, proc.returncode, stdout, stderr)


# `error: ...`, or argparse's `python -m app: error: ...` under its usage line
_ERROR_LINE = re.compile(r"^(python -m app: )?error: ")


def job_problems(res: subprocess.CompletedProcess) -> list[str]:
    """What is wrong with how a job ended, whatever its results: a hang (no exit status),
    a traceback, or a failure without exactly one `error:` line on stderr (argparse's
    `python -m app: error:` counts: before, it read as none)."""
    if res.returncode is None:
        return ["no exit within the timeout (hang)"]
    out = []
    if "Traceback" in res.stderr:
        out.append("traceback on stderr")
    errors = [x for x in res.stderr.splitlines() if _ERROR_LINE.match(x)]
    if res.returncode != 0 and len(errors) != 1:
        out.append(f"exit {res.returncode} with {len(errors)} 'error:' lines")
    return out


def _field(path: str) -> str:
    """The field a summary leaf belongs to: its path with list indices removed."""
    return re.sub(r"\[\d+\]", "", path)


def _family(field: str) -> str:
    """The group a field is judged in when its own values are round-off: its parent, at
    most three path components ('steps/reactions/support:base', 'steps/balance/bodies',
    'point_values/tip')."""
    parts = field.split("/")
    return "/".join(parts[:max(1, min(3, len(parts) - 1))])


def flatten(obj, path: str = "") -> dict[str, object]:
    """Leaves of a JSON document by path ('steps[0]/interfaces/bond/p' ...)."""
    if isinstance(obj, dict):
        out: dict[str, object] = {}
        for k, v in obj.items():
            if k not in VOLATILE:
                out.update(flatten(v, f"{path}/{k}" if path else k))
        return out
    if isinstance(obj, list):
        out = {}
        for i, v in enumerate(obj):
            out.update(flatten(v, f"{path}[{i}]"))
        return out
    return {path: obj}


def compare_summaries(a: dict, b: dict, roundoff: float) -> tuple[dict, list[str]]:
    """Max relative difference per summary field, and the exact mismatches."""
    fa, fb = flatten(a), flatten(b)
    for k in [k for k in fa if k.endswith("/mode") and "contact_held_modes" in k]:
        # the words for a combination fitted to a round-off slide name a random direction
        ratio = k[:-len("mode")] + "slide_ratio"
        if all(abs(f.get(ratio, 1.0)) < roundoff for f in (fa, fb)):
            fa.pop(k)
            fb.pop(k, None)
    mism = [f"summary key only in one run: {k}" for k in sorted(set(fa) ^ set(fb))
            if not SOLVER_PATH.search(k)]
    scale: dict[str, float] = {}
    for k in set(fa) & set(fb):
        for v in (fa[k], fb[k]):
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                for g in (_field(k), "family:" + _family(_field(k))):
                    scale[g] = max(scale.get(g, 0.0), abs(v))
    for g in [g for g in scale if not g.startswith("family:")]:
        # the run's final figures (strain_energy, ...) are those of the last step
        scale[g] = max(scale[g], scale.get("steps/" + g, 0.0))
        # a field whose every value is round-off next to its family (a zero reaction, a
        # floating body's net contact force) is judged against the family's size
        fam = scale["family:" + _family(g)]
        if scale[g] < FAMILY_ROUNDOFF * fam:
            scale[g] = fam
    diffs: dict[str, float] = {}
    for k in sorted(set(fa) & set(fb)):
        va, vb = fa[k], fb[k]
        if ROUNDOFF.search(k):
            for v in (va, vb):
                if isinstance(v, float) and abs(v) > roundoff and not k.endswith("residual"):
                    mism.append(f"{k} = {v:.3g} above round-off")
            continue
        if SOLVER_PATH.search(k):
            continue
        if isinstance(va, float) or isinstance(vb, float):
            if not isinstance(va, (int, float)) or not isinstance(vb, (int, float)):
                mism.append(f"{k}: {va!r} vs {vb!r}")
                continue
            s = scale.get(_field(k), 0.0)
            d = abs(va - vb) / s if s > 0 else 0.0
            diffs[_field(k)] = max(diffs.get(_field(k), 0.0), d)
        elif va != vb:
            mism.append(f"{k}: {str(va)[:80]!r} vs {str(vb)[:80]!r}")
    return diffs, mism


def h5_datasets(path: Path) -> dict[str, np.ndarray]:
    """Every dataset of an HDF5 file by its path, read through the links to an earlier
    step's copy (`step_datasets`), plus its attributes as '@attr'."""
    out = step_datasets(path)
    with h5py.File(path, "r") as f:
        for k, v in f.attrs.items():
            out[f"@{k}"] = np.asarray(v)
    return out


def compare_arrays(a: np.ndarray, b: np.ndarray) -> tuple[float, float] | str:
    """(max |a - b|, max |a|, |b|) of two arrays, or a string saying why they differ in
    kind (shape, integers, strings, where they are finite)."""
    if a.shape != b.shape:
        return f"shape {a.shape} vs {b.shape}"
    if a.dtype.kind not in "fiub" or b.dtype.kind not in "fiub":
        return (0.0, 0.0) if np.array_equal(a, b) else "different values"
    if a.dtype.kind in "iub" and b.dtype.kind in "iub":
        return (0.0, 0.0) if np.array_equal(a, b) else "different integers"
    a, b = a.astype(float), b.astype(float)
    if not np.array_equal(np.isfinite(a), np.isfinite(b)):
        return "non-finite entries differ"
    fin = np.isfinite(a)
    scale = max(np.abs(a[fin]).max(initial=0.0), np.abs(b[fin]).max(initial=0.0))
    return float(np.abs(a[fin] - b[fin]).max(initial=0.0)), float(scale)


def xdmf_steps(path: Path) -> list[str]:
    """The time values listed in an XDMF time series."""
    if not path.exists():
        return []
    return [t.get("Value") for t in ET.parse(path).getroot().iter("Time")]


def compare_outputs(ref: Path, other: Path, roundoff: float = 1e-7) -> tuple[dict, list[str]]:
    """Compare two output folders of the same scene: ({field: max rel. diff}, mismatches).

    Fields: `summary:<path>` per summary field, `<file>:<dataset>` per HDF5 dataset
    (step files grouped as `step:<dataset>`)."""
    diffs: dict[str, float] = {}
    mism: list[str] = []
    sa, sb = read_json(ref / "summary.json", ref), read_json(other / "summary.json", other)
    d, m = compare_summaries(sa, sb, roundoff)
    diffs.update({f"summary:{k}": v for k, v in d.items()})
    mism += m
    files_a = sorted(p.name for p in ref.glob("*.h5"))
    files_b = sorted(p.name for p in other.glob("*.h5"))
    if files_a != files_b:
        mism.append(f"h5 files {files_a} vs {files_b}")
    for name in ("results.xdmf", "contact.xdmf"):
        if xdmf_steps(ref / name) != xdmf_steps(other / name):
            mism.append(f"{name} times {xdmf_steps(ref / name)} vs {xdmf_steps(other / name)}")
        elif (ref / name).exists() != (other / name).exists() or ((ref / name).exists() and (
                xdmf_structure(ref / name, ref) != xdmf_structure(other / name, other))):
            mism.append(f"{name} differs in structure")  # the same XML text is expected
    delta: dict[str, list[float]] = {}  # field -> [max |a - b|, max |a|] over all steps
    for name in sorted(set(files_a) & set(files_b)):
        da, db = h5_datasets(ref / name), h5_datasets(other / name)
        group = "step" if name.startswith("step_") else name
        for k in sorted(set(da) ^ set(db)):
            mism.append(f"{name}: {k} only in one run")
        for k in sorted(set(da) & set(db)):
            r = compare_arrays(np.asarray(da[k]), np.asarray(db[k]))
            if isinstance(r, str):
                mism.append(f"{name}:{k}: {r}")
            else:
                acc = delta.setdefault(f"{group}:{k}", [0.0, 0.0])
                acc[0], acc[1] = max(acc[0], r[0]), max(acc[1], r[1])
    # a step whose field is round-off (no load) is judged against the field's size over
    # the whole run, a field that is round-off over the whole run against its family's
    fam = {f: max((delta.get(f"step:{k}", [0.0, 0.0])[1] for k in keys), default=0.0)
           for f, keys in H5_FAMILY.items()}
    for k, (d, s) in delta.items():
        f = next((f for f, keys in H5_FAMILY.items() if k.split(":", 1)[1] in keys), None)
        if f is not None and s < FAMILY_ROUNDOFF * fam[f]:
            s = fam[f]
        diffs[k] = d / s if s > 0 else 0.0
    return diffs, mism


def compare_csv(a: Path, b: Path, folder_a: Path, folder_b: Path) -> tuple[dict, list[str]]:
    """Compare two CSV tables of a study: ({column: max rel. diff}, mismatches). Rows in
    order; a number is judged against the column's largest |value|, text must be equal
    (the output folder's name excepted), wall-time columns are left out."""
    import csv

    ra, rb = (list(csv.DictReader(io.StringIO(outless(p, f))))
              for p, f in ((a, folder_a), (b, folder_b)))
    if len(ra) != len(rb) or (ra and list(ra[0]) != list(rb[0])):
        return {}, [f"{a.name}: {len(ra)} vs {len(rb)} rows or other columns"]
    diffs: dict[str, float] = {}
    mism: list[str] = []
    cols = [c for c in (ra[0] if ra else {}) if not CSV_VOLATILE.match(c)]
    for c in cols:
        va, vb = [_number(r[c]) for r in ra], [_number(r[c]) for r in rb]
        if any(isinstance(x, str) for x in va + vb):
            ta, tb = [r[c] for r in ra], [r[c] for r in rb]
            mism += [f"{a.name}:{c} row {i}: {x[:60]!r} vs {y[:60]!r}"
                     for i, (x, y) in enumerate(zip(ta, tb, strict=True)) if x != y]
            continue
        fa, fb = np.array(va, dtype=float), np.array(vb, dtype=float)
        if not np.array_equal(np.isfinite(fa), np.isfinite(fb)):
            mism.append(f"{a.name}:{c}: non-finite entries differ")
            continue
        fin = np.isfinite(fa)
        scale = max(np.abs(fa[fin]).max(initial=0.0), np.abs(fb[fin]).max(initial=0.0))
        d = np.abs(fa[fin] - fb[fin]).max(initial=0.0)
        diffs[f"{a.name}:{c}"] = float(d / scale) if scale > 0 else 0.0
    return diffs, mism


def _number(text: str) -> float | str:
    """A CSV cell as a float ('' and 'nan' are NaN), else the text."""
    try:
        return float(text) if text != "" else float("nan")
    except ValueError:
        return text


def outless(path: Path, folder: Path) -> str:
    """The text of a file with its run's output folder named OUT (an error message says
    where the completed steps are written)."""
    text = path.read_text()
    for name in sorted({str(folder), str(folder.resolve())}, key=len, reverse=True):
        text = text.replace(name, "OUT")
    return text


def xdmf_structure(path: Path, folder: Path) -> str:
    """An XDMF index's text (`outless`) with the step file of each HDF DataItem left out:
    an array equal to an earlier step's bits is read from that step's file, and a
    round-off difference between two runs can decide whether it is (the data itself
    is compared dataset by dataset)."""
    return re.sub(r">step_\d+\.h5:", ">step_N.h5:", outless(path, folder))


def read_json(path: Path, folder: Path):
    """A JSON file of an output folder, the folder's own name replaced by OUT."""
    return json.loads(outless(path, folder))


def compare_study(ref: Path, other: Path, roundoff: float = 1e-7) -> tuple[dict, list[str]]:
    """Compare two `study` output folders: its summary.json, every CSV table and every run
    folder (L0_4SD, run_000, ...) as compare_outputs does."""
    diffs: dict[str, float] = {}
    sa, sb = read_json(ref / "summary.json", ref), read_json(other / "summary.json", other)
    d, mism = compare_summaries(sa, sb, roundoff)
    diffs.update({f"summary:{k}": v for k, v in d.items()})
    for name in STUDY_CSV:
        if (ref / name).exists() != (other / name).exists():
            mism.append(f"{name} only in one run")
        elif (ref / name).exists():
            d, m = compare_csv(ref / name, other / name, ref, other)
            diffs.update(d)
            mism += m
    runs_a = sorted(p.name for p in ref.iterdir() if (p / "summary.json").exists())
    runs_b = sorted(p.name for p in other.iterdir() if (p / "summary.json").exists())
    if runs_a != runs_b:
        mism.append(f"runs {runs_a} vs {runs_b}")
    for name in sorted(set(runs_a) & set(runs_b)):
        d, m = compare_outputs(ref / name, other / name, roundoff)
        diffs.update({f"{name}/{k}": v for k, v in d.items()})
        mism += [f"{name}: {x}" for x in m]
    return diffs, mism


def headline(diffs: dict[str, float]) -> dict[str, float]:
    """Max relative difference by kind: summary, displacement, stress, contact, other and
    table (a study's CSV files)."""
    out = {"summary": 0.0, "displacement": 0.0, "stress": 0.0, "contact": 0.0, "other": 0.0,
           "table": 0.0}
    for k, v in diffs.items():
        k = re.sub(r"^[^:/]+/(?=(summary|step|mesh\.h5):)", "", k)  # a study's run folder
        if ".csv:" in k:
            kind = "table"
        elif k.startswith("summary:"):
            kind = "summary"
        elif "contact/" in k:
            kind = "contact"
        elif k.endswith("displacement"):
            kind = "displacement"
        elif re.search(r"(stress|s_xx|s_yy|s_xy|s_zz|von_mises|strain_energy_density)$", k):
            kind = "stress"
        else:
            kind = "other"
        out[kind] = max(out[kind], v)
    return {k: float(f"{v:.3g}") for k, v in out.items()}


def failed_alike(summary: dict, args: list[str] | None = None) -> dict:
    """What a row whose runs agree adds when they did not complete: {} for `completed`;
    for a scene of EXPECTED_FAILURES (run without options) whose error has its words,
    `expected_failure` (the error; the verdict stays ok); else `verdict` "FAILED ALIKE"
    and the `error`: nothing but the failure was compared, so the scene is not checked
    (before, such a row read ok: `--bogus` passed on every scene)."""
    status = summary.get("status")
    if status == "completed":
        return {}
    error = str(summary.get("error", f"status {status!r}"))
    words = EXPECTED_FAILURES.get(Path(str(summary.get("config", ""))).stem)
    if words and not args and status == "failed" and words in error:
        return {"expected_failure": error}
    return {"verdict": "FAILED ALIKE", "error": error}


def check(config: Path, args: list[str], ranks: list[int], tol: float, roundoff: float,
          timeout: float, keep: Path | None, command: str = "run") -> list[dict]:
    """Run one scene on every rank count and compare each with the first; the exit
    statuses must be equal too, and each job free of the problems of job_problems."""
    base = Path(tempfile.mkdtemp(prefix="check_ranks_", dir=keep))
    compare = compare_study if command == "study" else compare_outputs
    rows = []
    try:
        outs, status, jobs = {}, {}, {}
        for n in ranks:
            out = base / f"n{n}"
            jobs[n] = res = run(config, args, n, out, timeout, command)
            outs[n] = out
            path = out / "summary.json"
            status[n] = (json.loads(path.read_text()).get("status") if path.exists()
                         else f"no summary (exit {res.returncode}): {res.stderr[-200:]}")
        n0 = ranks[0]
        for n in ranks[1:]:
            row = {"config": str(config.relative_to(ROOT) if config.is_relative_to(ROOT)
                                 else config), "args": args, "ranks": n,
                   "against": n0, "status": [status[n0], status[n]],
                   "exit": [jobs[n0].returncode, jobs[n].returncode]}
            job = [f"{k} ranks: {p}" for k in (n0, n) for p in job_problems(jobs[k])]
            if jobs[n0].returncode != jobs[n].returncode:
                job.append(f"exit {jobs[n0].returncode} vs {jobs[n].returncode}")
            if not (outs[n0] / "summary.json").exists() or not (outs[n] / "summary.json").exists():
                row.update(verdict="DIFFERENT", mismatches=job + ["no summary.json"])
                rows.append(row)
                continue
            diffs, mism = compare(outs[n0], outs[n], roundoff)
            mism = job + mism
            worst = max(diffs.items(), key=lambda kv: kv[1], default=("", 0.0))
            row.update(max_rel_diff=headline(diffs), worst=[worst[0], float(f"{worst[1]:.3g}")],
                       mismatches=mism[:20], n_mismatches=len(mism))
            row["verdict"] = "ok" if not mism and worst[1] <= tol else "DIFFERENT"
            if row["verdict"] == "ok":
                summary = json.loads((outs[n0] / "summary.json").read_text())
                row.update(failed_alike({**summary, "config": str(config)}, args))
            if keep is not None:
                row["out"] = str(base)
            rows.append(row)
    finally:
        if keep is None:
            shutil.rmtree(base, ignore_errors=True)
    return rows


def compare_folders(ref: Path, other: Path, tol: float, roundoff: float) -> int:
    """Print the comparison of two existing output folders as one JSON line; 1 if they
    differ."""
    study = (ref / "study.csv").exists() or (ref / "sweep.csv").exists()
    diffs, mism = (compare_study if study else compare_outputs)(ref, other, roundoff)
    worst = max(diffs.items(), key=lambda kv: kv[1], default=("", 0.0))
    row = {"ref": str(ref), "other": str(other), "max_rel_diff": headline(diffs),
           "worst": [worst[0], float(f"{worst[1]:.3g}")], "mismatches": mism[:20],
           "n_mismatches": len(mism),
           "verdict": "ok" if not mism and worst[1] <= tol else "DIFFERENT"}
    if row["verdict"] == "ok":  # the run's own options are not known here: its config's
        row.update(failed_alike(json.loads((ref / "summary.json").read_text())))
    print(json.dumps(row), flush=True)
    return 0 if row["verdict"] == "ok" else 1


def output_runs(tree: Path) -> list[str]:
    """The outputs below `tree` (a folder with no summary.json of its own): the relative
    paths of the folders that hold a summary.json, each a run's or a study's (a study's
    run folders are its own, not listed apart), sorted."""
    found = sorted(p.parent for p in tree.rglob("summary.json"))
    tops: list[Path] = []
    for folder in found:  # parents sort before their children
        if not any(top in folder.parents for top in tops):
            tops.append(folder)
    return [str(p.relative_to(tree)) for p in tops]


def compare_trees(ref: Path, other: Path, tol: float, roundoff: float) -> int:
    """`--compare` on two folders: two outputs (a run's or a study's, summary.json at the
    top) compared as one; two trees of outputs, every output below compared with the one
    at the same relative path (one JSON line each, and one for the outputs found in one
    tree only). 0 if all agree, 1 if any differ, 2 (one `error:` line) when the folders
    are neither."""
    for folder in (ref, other):
        if not folder.is_dir():
            return _usage_error(f"{folder} is not a folder")
    tops = [(f / "summary.json").exists() for f in (ref, other)]
    if all(tops):
        return compare_folders(ref, other, tol, roundoff)
    if any(tops):
        one, two = (ref, other) if tops[0] else (other, ref)
        return _usage_error(f"{one} is an output (summary.json at its top) but {two} is not")
    runs = {f: output_runs(f) for f in (ref, other)}
    if not runs[ref] and not runs[other]:
        return _usage_error(f"no summary.json below {ref} or {other}")
    bad = 0
    for rel in sorted(set(runs[ref]) & set(runs[other])):
        bad += compare_folders(ref / rel, other / rel, tol, roundoff)
    alone = {str(f): sorted(set(runs[f]) - set(runs[g]))
             for f, g in ((ref, other), (other, ref))}
    if any(alone.values()):
        print(json.dumps({"ref": str(ref), "other": str(other), "only_in": alone,
                          "verdict": "DIFFERENT"}), flush=True)
        bad += 1
    return 1 if bad else 0


def _usage_error(what: str) -> int:
    """One `error:` line on stderr for --compare's folders; exit status 2."""
    print(f"error: --compare {what}: give two output folders (each with summary.json) or "
          "two folders of outputs (compared by relative path)", file=sys.stderr)
    return 2


def _check_arguments(ap: argparse.ArgumentParser, a: argparse.Namespace) -> None:
    """What cannot be compared stops with `error:`, exit 2: before, a missing CONFIG failed
    alike on every rank count and read `ok`. (--compare's folders: `compare_trees`, one line.)"""
    if a.compare:
        return
    missing = [str(c) for c in a.configs if not c.is_file()]
    if missing:
        ap.error(f"config file {missing[0]!r} does not exist")
    if len(a.ranks) < 2 or min(a.ranks) < 1:
        ap.error("--ranks needs the reference count and at least one more, all >= 1 "
                 "(e.g. --ranks 1 2)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("configs", nargs="*", type=Path,
                    help="scenes (default: configs/*.toml and configs/hard/*.toml)")
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--variants", choices=["scene", "bulk"], default="scene",
                    help="bulk: each of --sd 1 2 3 4 8 16 and --method fem-q4")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--roundoff", type=float, default=1e-7)
    ap.add_argument("--timeout", type=float, default=900)
    ap.add_argument("--full", action="store_true", help=f"no cheap settings for {list(CHEAP)}")
    ap.add_argument("--keep", type=Path, help="keep the outputs under this folder")
    ap.add_argument("--skip", nargs="*", default=[], help="scene names to leave out")
    ap.add_argument("--command", choices=["run", "study"], default="run",
                    help="study: `python -m app study` (give its options, e.g. --levels 2 "
                         "or --sweep KEY=V1,V2), its tables and every run folder compared")
    ap.add_argument("--compare", type=Path, nargs=2, metavar=("REF", "OTHER"),
                    help="only compare two output folders that exist (a run's or a study's), "
                         "or two folders of them: every output below, paired by relative "
                         "path (one JSON line each)")
    a, extra = ap.parse_known_args()  # the rest goes to every run, e.g. --mesh-size 1.0
    _check_arguments(ap, a)
    if a.compare:
        sys.exit(compare_trees(*a.compare, a.tol, a.roundoff))
    configs = a.configs or sorted((ROOT / "configs").glob("*.toml")) + sorted(
        (ROOT / "configs" / "hard").glob("*.toml"))
    variants = BULK_VARIANTS if a.variants == "bulk" else [[]]
    if a.keep:
        a.keep.mkdir(parents=True, exist_ok=True)
    bad = 0
    for config in configs:
        config = config.resolve()
        if config.stem in a.skip:
            continue
        for v in variants:
            args = (CHEAP.get(config.stem, []) if not a.full else []) + v + extra
            for row in check(config, args, a.ranks, a.tol, a.roundoff, a.timeout, a.keep,
                             a.command):
                bad += row["verdict"] != "ok"
                print(json.dumps(row), flush=True)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
