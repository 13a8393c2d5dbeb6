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
    version = app_version(tmp_path)  # no pyproject.toml there: the installed metadata
    assert version is None or isinstance(version, str)
