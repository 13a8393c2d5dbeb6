"""summary.json `provenance.version.app` is the project's version (it was always null:
provenance read `app.__version__`, which the package never defined)."""

import tomllib

from support import ROOT

from app.output.provenance import app_version, provenance


def test_app_version_is_the_projects():
    expected = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert app_version() == expected
    assert provenance({}, [], 1)["version"]["app"] == expected


def test_app_version_outside_a_checkout(tmp_path):
    from importlib import metadata

    try:
        installed = metadata.version("csfem-contact")
    except metadata.PackageNotFoundError:
        installed = None
    assert app_version(tmp_path) == installed  # no pyproject.toml there: the metadata
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "other"\nversion = "9.9"\n')
    assert app_version(tmp_path) == installed  # another project's pyproject is not ours
