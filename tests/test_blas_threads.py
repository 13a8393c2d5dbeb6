"""BLAS threads: several ranks on a node get cores // ranks threads each unless the user set
OPENBLAS_NUM_THREADS / OMP_NUM_THREADS / MKL_NUM_THREADS (app/blas_threads.py), chosen
before numpy loads and recorded in summary.json's `provenance.blas_threads` (before:
nothing set, every rank of `mpiexec --bind-to none -n 2` started one OpenBLAS thread a
core, 4 threads on 2 cores, and summary.json did not say)."""

import os
import shutil
import subprocess
import sys

import pytest
from support import CONFIGS, ROOT, mpi_env, read_summary

from app.blas_threads import THREAD_VARS, choose


@pytest.mark.parametrize("ranks, cores, expected", [(2, 2, "1"), (2, 8, "4"), (3, 2, "1"),
                                                    (4, 16, "4")])
def test_several_ranks_get_cores_over_ranks(ranks, cores, expected):
    env = {"OMPI_COMM_WORLD_SIZE": str(ranks)}
    chosen = choose(env, cores=cores)
    assert env["OPENBLAS_NUM_THREADS"] == env["OMP_NUM_THREADS"] == expected
    assert chosen["set_by"].startswith("app") and chosen["ranks_on_node"] == ranks


def test_ranks_on_the_node_count_not_the_world():
    env = {"OMPI_COMM_WORLD_SIZE": "8", "OMPI_COMM_WORLD_LOCAL_SIZE": "2"}
    choose(env, cores=8)
    assert env["OPENBLAS_NUM_THREADS"] == "4"  # 2 ranks share this node's 8 cores
    env = {"PMI_SIZE": "2"}  # MPICH's hydra
    choose(env, cores=8)
    assert env["OPENBLAS_NUM_THREADS"] == "4"


def test_one_rank_keeps_the_library_default():
    env: dict[str, str] = {}
    chosen = choose(env, cores=8)
    assert env == {} and chosen["set_by"].startswith("library default")


@pytest.mark.parametrize("var", THREAD_VARS)
def test_a_users_setting_wins(var):
    env = {"OMPI_COMM_WORLD_SIZE": "2", var: "3"}
    chosen = choose(env, cores=2)
    assert env == {"OMPI_COMM_WORLD_SIZE": "2", var: "3"}  # nothing added
    assert chosen["set_by"] == "user" and chosen["variables"] == {var: "3"}


def _env_without_threads() -> dict[str, str]:
    return {k: v for k, v in mpi_env().items() if k not in THREAD_VARS}


def _run(tmp_path, env: dict[str, str], ranks: int, tag: str) -> dict:
    """provenance.blas_threads of a 1-step patch run, under `mpiexec --bind-to none` (every
    rank may use every core, as under a launcher that does not bind) for ranks > 1."""
    out = tmp_path / tag
    cmd = [sys.executable, "-m", "app", "run", str(CONFIGS / "patch.toml"), "--out", str(out),
           "--quiet", "--mesh-size", "0.5", "--set", "analysis.steps=1"]
    if ranks > 1:
        cmd = [shutil.which("mpiexec") or "mpiexec", "--bind-to", "none", "-n", str(ranks),
               *cmd]
    res = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    return read_summary(out)["provenance"]["blas_threads"]


def test_mpiexec_run_applies_the_default_and_records_it(tmp_path):
    expected = max(1, (os.cpu_count() or 1) // 2)
    record = _run(tmp_path, _env_without_threads(), 2, "app")
    assert record["set_by"].startswith("app") and record["ranks_on_node"] == 2
    assert record["variables"] == {"OPENBLAS_NUM_THREADS": str(expected),
                                   "OMP_NUM_THREADS": str(expected)}
    if sys.platform == "linux":  # numpy's and PETSc's OpenBLAS, as each reports it
        assert record["libraries"] and set(record["libraries"].values()) == {expected}
        assert record["threads"] == expected


def test_mpiexec_run_keeps_the_users_setting(tmp_path):
    cores = os.cpu_count() or 1
    env = _env_without_threads() | {"OPENBLAS_NUM_THREADS": str(cores)}
    record = _run(tmp_path, env, 2, "user")
    assert record["set_by"] == "user"
    assert record["variables"] == {"OPENBLAS_NUM_THREADS": str(cores)}
    if sys.platform == "linux":
        assert record["threads"] == cores


def test_one_rank_run_records_the_library_default(tmp_path):
    record = _run(tmp_path, _env_without_threads(), 1, "one")
    assert record["set_by"].startswith("library default") and "variables" not in record
    if sys.platform == "linux":
        assert 1 <= record["threads"] <= len(os.sched_getaffinity(0))  # one a core, capped
        # by the library's build (numpy's wheel: MAX_THREADS)


@pytest.mark.skipif(not os.path.exists("/proc/self/maps"), reason="needs /proc/self/maps")
def test_an_openblas_under_a_path_with_spaces_is_recorded(tmp_path):
    """/proc/self/maps ends a line with the path, which may hold spaces (a venv under
    "/home/a b/"): the whole path is read, not its last word (before: the library was
    silently left out of `libraries`)."""
    import numpy  # noqa: F401  (loads numpy's OpenBLAS: the library copied below)

    from app.blas_threads import loaded_openblas_threads
    with open("/proc/self/maps") as maps:
        found = sorted({line.split(maxsplit=5)[-1].strip() for line in maps
                        if "libopenblas" in line and "/" in line})
    if not found:
        pytest.skip("numpy has no OpenBLAS of its own here")
    spaced = tmp_path / "a b" / "libopenblas_spaced.so"
    spaced.parent.mkdir()
    shutil.copy(found[0], spaced)
    code = ("import ctypes, sys\nimport numpy\nctypes.CDLL(sys.argv[1])\n"  # (numpy: its
            # libgfortran, which the copy needs)
            "from app.blas_threads import loaded_openblas_threads as f\nprint(f())")
    res = subprocess.run([sys.executable, "-c", code, str(spaced)], cwd=ROOT,
                         capture_output=True, text=True, timeout=60,
                         env=os.environ | {"OPENBLAS_NUM_THREADS": "1"})
    assert res.returncode == 0, res.stderr[-2000:]
    assert "'libopenblas_spaced.so': 1" in res.stdout, res.stdout
    assert loaded_openblas_threads()  # this process's own libraries still read
