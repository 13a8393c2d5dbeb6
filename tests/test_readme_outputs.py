"""Every summary.json key and step-file dataset README.md documents ("Output", "Contact
data in `step_NNNN.h5`", "summary.json") is in a current run's output: the names are
read from the README's tables, so a row added there is checked too, and a key the code
stops writing (or renames) fails here instead of leaving the README promising it."""

from __future__ import annotations

import re
from pathlib import Path

import h5py
import pytest
from support import ROOT, read_summary, run_cli

from app.output.read import step_datasets

README = (ROOT / "README.md").read_text(encoding="utf-8")

# Keys the README documents as present only in some runs, with the README's condition.
CONDITIONAL = {
    "stopped_in_phase": "a failed or interrupted run that stopped inside a phase",
    "undetermined_modes": "only when there are some",
}


def section(title: str) -> str:
    """The README's text from the heading `title` to the next heading of any level."""
    body = README.split(f"\n{title}\n", 1)[1]
    return re.split(r"\n#{2,6} ", body, maxsplit=1)[0]


def first_column_names(text: str) -> list[str]:
    """The backticked names in the first column of the text's tables."""
    names = []
    for line in text.splitlines():
        if line.startswith("| `"):
            names += re.findall(r"`([^`]+)`", line.split("|")[1])
    return names


CONTACT_TABLE = "### Contact data in `step_NNNN.h5`, group `/contact` (m pairs)"


def test_the_readme_tables_are_found():
    """A guard on the parsing itself: the tables still have the rows it reads."""
    keys = first_column_names(section("### summary.json"))
    assert {"status", "timings", "steps[k]", "kkt_pairs", "lcp_accuracy"} <= set(keys)
    assert {"p", "g_cols", "state"} <= set(first_column_names(section(CONTACT_TABLE)))


@pytest.fixture(scope="module")
def hertz_run(tmp_path_factory) -> Path:
    """hertz.toml, coarse, with every optional part the README names switched on: the
    energy bracket, an unused PETSc option, and (at this mesh) a contact-held-mode warning."""
    out = tmp_path_factory.mktemp("readme") / "hertz"
    proc = run_cli(["run", "configs/hertz.toml", "--mesh-size", "2.0", "--energy-bracket",
                    "--quiet", "--out", str(out), "-readme_unused_option", "1"], timeout=300)
    assert proc.returncode == 0, proc.stderr
    return out


def lookup(node: object, dotted: str) -> bool:
    """Whether the README's name (`a.b`, `steps[k].x`, `x.<name>`: any entry) is in node."""
    for part in dotted.replace("steps[k]", "steps").split("."):
        if isinstance(node, list):
            node = node[0] if node else {}
        if not isinstance(node, dict):
            return False
        if part.startswith("<") and part.endswith(">"):
            if not node:
                return False
            node = next(iter(node.values()))
        elif part in node:
            node = node[part]
        else:
            return False
    return True


def test_every_documented_summary_key_is_written(hertz_run):
    d = read_summary(hertz_run)
    step = d["steps"][0]
    keys = first_column_names(section("### summary.json"))
    missing = [k for k in keys if k not in CONDITIONAL
               and not (lookup(d, k) or lookup(step, k))]
    assert missing == []


def test_the_documented_sub_keys_are_written(hertz_run):
    """The keys the README's summary.json rows list inside a value."""
    d = read_summary(hertz_run)
    s = d["steps"][0]
    want = {
        "provenance": (d["provenance"], "start_time ranks argv overrides config_resolved "
                       "petsc_options version host out blas_threads"),
        "provenance.version": (d["provenance"]["version"], "app git python petsc"),
        "provenance.blas_threads": (d["provenance"]["blas_threads"], "threads libraries "
                                    "set_by variables ranks_on_node"),
        "timings": (d["timings"], "startup launch mesh setup floating_modes assembly "
                    "boundary_conditions factorization solve output reference "
                    "energy_bracket total pair_search compliance lcp recovery"),
        "mesh_quality": (d["mesh_quality"], "min_corner_angle_deg max_corner_angle_deg "
                         "max_aspect_ratio min_angle_at"),
        "contact_interfaces.<name>": (next(iter(d["contact_interfaces"].values())),
                                      "discretisation master_interpolation n_pairs pairs_on"),
        "reference (hertz)": (d["reference"]["hertz"], "p_max_rel_error half_width_rel_error "
                              "pressure_l2_rel_error pressure_l2_interp_floor"),
        "energy_bracket": (d["energy_bracket"], "upper lower upper_method lower_method "
                           "width width_rel contains_run extra_runs"),
        "steps[k]": (s, "step load_factor strain_energy strain_energy_by_body step_seconds "
                     "elapsed_seconds reactions balance"),
        "steps[k].reactions.<support>": (next(iter(s["reactions"].values())),
                                         "Fx Fy Mz Mz_centroid centroid"),
        "steps[k].balance": (s["balance"], "bodies max_relative_residual force_scale"),
        "steps[k].balance.bodies.<name>": (next(iter(s["balance"]["bodies"].values())),
                                           "loads reactions contact residual relative_residual"),
        "interfaces.<name>": (next(iter(s["interfaces"].values())),
                              "n_pairs normal_force tangential_force force max_pressure states "
                              "state_lengths contact_length debonded_pairs "
                              "bond_strength_force dissipation"),
        "kkt_pairs": (s["kkt_pairs"], "normal tangential consistency interface pair "
                      "by_interface"),
        "rigid_motion.<body>": (next(iter(s["rigid_motion"].values())),
                                "translation rotation centroid"),
        "contact_held_modes[0]": (s["contact_held_modes"][0], "body mode interface slide "
                                  "contact_width slide_ratio warn"),
    }
    missing = {name: sorted(set(keys.split()) - set(value)) for name, (value, keys) in want.items()}
    assert {k: v for k, v in missing.items() if v} == {}
    assert d["petsc_options_unused"] == ["-readme_unused_option"]
    assert d["warnings"]


def test_every_documented_step_dataset_is_written(hertz_run):
    contact = first_column_names(section(CONTACT_TABLE))
    fields = ["displacement", "stress", "s_xx", "s_yy", "s_xy", "s_zz", "von_mises",
              "strain_energy_density", "body_id", "load_factor"]  # README "Output"
    have = set(step_datasets(hertz_run / "step_0001.h5"))
    assert sorted(({f"contact/{n}" for n in contact} | set(fields)) - have) == []
    with h5py.File(hertz_run / "step_0001.h5") as f:
        names = [str(n) for n in f.attrs["load_factor_names"]]
    assert names == list(read_summary(hertz_run)["steps"][0]["load_factor"])
    with h5py.File(hertz_run / "mesh.h5") as f:
        assert "body" in f  # `/body_id` links to `/body` of mesh.h5 (README "Output")


def test_a_failed_run_writes_the_documented_failure_keys(tmp_path):
    """`status` `failed`, `error` and `failed_step` (also before step 1)."""
    proc = run_cli(["run", "configs/hertz.toml", "--mesh-size", "2.0", "--quiet", "--out",
                    str(tmp_path), "--set", "interface.contact.mu=-1"], timeout=120)
    assert proc.returncode == 2
    d = read_summary(tmp_path)
    assert d["status"] == "failed" and d["error"] and d["failed_step"] == 1


# Paths the README names that are not meant to exist: placeholders, the extension
# examples of "Extension points" (files a user would add), and a module it says is gone.
NOT_FILES = {"configs/NAME.toml", "configs/hard/SCENE.toml", "meshes/x.msh",
             "app/references/punch.py", "app/scene/shapes/rounded_rectangle.py",
             "app/contact/smooth_ends.py"}


def test_every_file_and_test_the_readme_names_exists():
    """A command or pointer into the tree (scripts/, configs/, tests/, app/, meshes/, docs/)
    names a file that is there, and a `tests/x.py::name` a test that is there."""
    paths = set(re.findall(r"(?<![\w/.])((?:scripts|configs|tests|app|meshes|docs)/"
                           r"[\w./-]+\.(?:py|toml|c|msh|png|sh|md))", README))
    assert len(paths) > 100  # the pattern still finds the README's paths
    assert sorted(p for p in paths - NOT_FILES if not (ROOT / p).exists()) == []
    missing = []
    for path, name in set(re.findall(r"(tests/[\w/]+\.py)::(\w+)", README)):
        text = (ROOT / path).read_text(encoding="utf-8")
        if not re.search(rf"^(?:def|class) {name}\b", text, flags=re.M):
            missing.append(f"{path}::{name}")
    assert sorted(missing) == []
