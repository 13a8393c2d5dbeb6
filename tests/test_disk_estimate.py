"""A run whose step files would not fit on OUT's disk is refused before meshing
(app/mesh/estimate.py, check_disk; called from app/cli.py, check_run_input).

Before, only memory was estimated: `--set analysis.steps=1000 --mesh-size 0.01` on
patch.toml (1e5 DOFs estimated) wrote 202 step files in its first 2 minutes, and
`analysis.steps = 100000` would have gone on until the disk was full.
"""

from argparse import Namespace
from collections import namedtuple

import pytest
from support import CONFIGS

from app.cli import check_run_input
from app.config import load_config
from app.errors import InputError
from app.mesh import estimate

Usage = namedtuple("Usage", "total used free")


@pytest.fixture
def one_gb_free(monkeypatch):
    monkeypatch.setattr(estimate.shutil, "disk_usage", lambda path: Usage(2e9, 1e9, 1e9))


def _args(out, mesh_size=None, allow_large=False) -> Namespace:
    return Namespace(mesh_size=mesh_size, out=str(out), allow_large=allow_large)


def test_step_files_beyond_the_free_disk_are_refused(tmp_path, one_gb_free):
    cfg = load_config(CONFIGS / "patch.toml", ["analysis.steps=1000"])
    with pytest.raises(InputError, match=r"the run's 1000 step files would need about 5.17 "
                                         r"GB .* more than the 1 GB free on the disk of"):
        check_run_input(cfg, _args(tmp_path / "new" / "out", mesh_size=0.01))


def test_runs_that_fit_or_are_allowed_pass(tmp_path, one_gb_free):
    cfg = load_config(CONFIGS / "patch.toml", ["analysis.steps=1000"])
    check_run_input(cfg, _args(tmp_path, mesh_size=0.01, allow_large=True))
    check_run_input(cfg, _args(tmp_path))  # the config's own mesh: 0.03 GB
    check_run_input(load_config(CONFIGS / "patch.toml"), _args(tmp_path, mesh_size=0.01))



def test_an_unusable_out_is_left_to_the_out_check(tmp_path):
    """A 300-character --out made Path.exists raise (File name too long): the fuzzer's
    regression case then saw an OSError traceback."""
    cfg = load_config(CONFIGS / "patch.toml")
    check_run_input(cfg, _args(tmp_path / ("n" * 300) / "x"))


def _study(**kw) -> Namespace:
    given = dict(sweep=None, methods="4,q4", first_level=0, reference_levels=0)
    return Namespace(**{**given, **kw})


def test_a_study_counts_all_its_runs(tmp_path, one_gb_free):
    """Before, a study's check counted its finest run only: `study --methods 4,q4
    --levels 3` writes 2 x (1/16 + 1/4 + 1) of that run's DOFs, a sweep one run per
    combination."""
    from app.cli import _study_runs

    cfg = load_config(CONFIGS / "patch.toml", ["analysis.steps=1000"])
    args = _args(tmp_path, mesh_size=0.16)
    check_run_input(cfg, args, 2)  # the finest run alone: about 0.37 GB
    runs = _study_runs(_study(), 2)
    assert sorted(runs) == [1 / 16, 1 / 16, 1 / 4, 1 / 4, 1, 1]
    with pytest.raises(InputError, match=r"the study's 6 runs' 1000 step files would need "
                                         r"about 1.\d* GB \(.* DOFs each at the finest level\)"):
        check_run_input(cfg, args, 2, runs)
    assert _study_runs(_study(reference_levels=1), 2) == [1 / 16, 1 / 16, 1 / 4, 1 / 4, 1]
    sweep = _study(sweep=["interface.interface.mu=0.1,0.2", "body.lower.E=1,2,3"])
    assert _study_runs(sweep, 0) == [1.0] * 6


def _free(monkeypatch, free: float) -> None:
    monkeypatch.setattr(estimate.shutil, "disk_usage", lambda path: Usage(2 * free, free, free))


def test_the_xdmf_and_summary_growth_is_counted(tmp_path, monkeypatch):
    """patch.toml at 50 steps wrote 2.08 MB (`du -sb OUT`): the step files 1.45 MB, the
    XDMF files and summary.json about 13 kB per step. Before, 1.63 MB was estimated and
    the run passed the check on a 2 MB disk, then ran out of space."""
    cfg = load_config(CONFIGS / "patch.toml", ["analysis.steps=50"])
    _free(monkeypatch, 2e6)
    with pytest.raises(InputError, match=r"50 step files would need about 0.0026\d* GB"):
        check_run_input(cfg, _args(tmp_path))
    _free(monkeypatch, 3e6)  # fits with a margin: passes
    check_run_input(cfg, _args(tmp_path))


def test_a_mesh_file_is_counted(tmp_path, monkeypatch):
    """Before, a mesh.file run had no estimate (None without a DOF count): no disk check."""
    cfg = load_config(CONFIGS.parent / "meshes" / "punch.toml", ["analysis.steps=100"])
    _free(monkeypatch, 1e6)
    with pytest.raises(InputError, match=r"the run's 100 step files would need"):
        check_run_input(cfg, _args(tmp_path))
    _free(monkeypatch, 1e9)
    check_run_input(cfg, _args(tmp_path))
