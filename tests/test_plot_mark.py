"""A rerun into a used --out folder: the earlier run's step files go (README "Output"),
and so do the pictures scripts/plot_results.py drew from them (before, they stayed and
showed the earlier run's results next to this run's files); a user's own PNG stays."""

from __future__ import annotations

import json
import subprocess
import sys

from support import CONFIGS, ROOT, mpi_env, run_cli

from app.output import plot_mark, status
from app.plotting import pyplot

plt = pyplot()  # Agg, without the warning of a second matplotlib on the path


def _png(path, metadata=None) -> None:
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [0, 1])
    fig.savefig(path, metadata=metadata)
    plt.close(fig)


def test_only_marked_pngs_are_the_tools(tmp_path):
    _png(tmp_path / "mine.png")
    _png(tmp_path / "other.png", {"Source": "something else"})
    _png(tmp_path / "plot.png", plot_mark.METADATA)
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00")
    assert [p.name for p in sorted(tmp_path.iterdir()) if plot_mark.is_marked(p)] == [
        "plot.png"]
    assert status.clear_files(tmp_path, also=plot_mark.is_marked_png) == ["plot.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.png", "mine.png",
                                                           "other.png"]


def test_a_rerun_removes_the_earlier_runs_steps_and_plots(tmp_path):
    out = tmp_path / "o"
    first = run_cli(["run", str(CONFIGS / "hertz.toml"), "--set", "analysis.steps=4",
                     "--mesh-size", "2", "--out", str(out), "--quiet"])
    assert first.returncode == 0, first.stderr
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "plot_results.py"), str(out)],
                         cwd=ROOT, env=mpi_env(), capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    plots = sorted(p.name for p in out.glob("*.png"))
    assert plots and all(plot_mark.is_marked(out / p) for p in plots), plots
    _png(out / "notes.png")  # the user's own picture
    again = run_cli(["run", str(CONFIGS / "hertz.toml"), "--set", "analysis.steps=2",
                     "--mesh-size", "2", "--out", str(out), "--quiet"])
    assert again.returncode == 0, again.stderr
    assert sorted(p.name for p in out.glob("step_*.h5")) == ["step_0001.h5", "step_0002.h5"]
    assert sorted(p.name for p in out.glob("*.png")) == ["notes.png"]
    assert len(json.loads((out / "summary.json").read_text())["steps"]) == 2
    grids = (out / "results.xdmf").read_text().count("step_00")
    assert 0 < grids and "step_0003" not in (out / "results.xdmf").read_text()
