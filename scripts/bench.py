"""One runner for every benchmark in scripts/ (bench_NAME.py): runs it, tags each JSON line
it prints with the benchmark's name, the commit and the time, and appends them to a log.

    .venv/bin/python scripts/bench.py --list
    .venv/bin/python scripts/bench.py lemke -- --n 1500 3000 6000 --siconos
    .venv/bin/python scripts/bench.py many_steps phases --log out/bench.jsonl

Arguments after `--` go to every benchmark named. Exit status: the first non-zero one.
"""

from __future__ import annotations

import argparse
import ast
import json
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from app_runner import ENV, ROOT  # noqa: E402


def benchmarks() -> dict[str, str]:
    """name -> first line of the docstring, for every scripts/bench_NAME.py."""
    out = {}
    for path in sorted(HERE.glob("bench_*.py")):
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
        out[path.stem[len("bench_"):]] = doc.splitlines()[0] if doc else ""
    return out


def commit() -> str:
    res = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                         capture_output=True, text=True)
    return res.stdout.strip() if res.returncode == 0 else "unknown"


def run_one(name: str, args: list[str], log: Path | None) -> int:
    """Run bench_NAME.py; JSON lines are tagged and echoed, other lines go to stderr."""
    cmd = [sys.executable, str(HERE / f"bench_{name}.py"), *args]
    tag = {"benchmark": name, "commit": commit(), "started": time.strftime("%Y-%m-%dT%H:%M:%S")}
    proc = subprocess.Popen(cmd, cwd=ROOT, env=ENV, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            print(line, end="", file=sys.stderr)
            continue
        text = json.dumps(tag | record if isinstance(record, dict) else tag | {"value": record})
        print(text, flush=True)
        if log is not None:
            with log.open("a") as fh:
                fh.write(text + "\n")
    return proc.wait()


def main() -> int:
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[: argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", help="benchmarks to run (see --list)")
    ap.add_argument("--list", action="store_true", help="list the benchmarks")
    ap.add_argument("--log", type=Path, default=None, help="append the JSON lines here")
    args = ap.parse_args(argv)
    known = benchmarks()
    if args.list or not args.names:
        for name, doc in known.items():
            print(f"{name:<14s} {doc}")
        return 0
    unknown = [n for n in args.names if n not in known]
    if unknown:
        print(f"error: unknown benchmark(s) {unknown}: use one of {list(known)}",
              file=sys.stderr)
        return 2
    status = 0
    for name in args.names:
        status = status or run_one(name, extra, args.log)
    return status


if __name__ == "__main__":
    sys.exit(main())
