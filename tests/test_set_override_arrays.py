"""`--set` on an array of tables the config does not have yet: index 0 appends one."""

import pytest

from app.config import apply_overrides
from app.errors import InputError


def test_index_zero_of_a_missing_array_makes_the_array() -> None:
    """README: the index one past the end appends an entry; before, `mesh.patch.0.box` on a
    config without patches made a table {"0": ...} ("mesh.patch must be an array")."""
    raw = {"mesh": {"size": 0.5}}
    apply_overrides(raw, ["mesh.patch.0.box=[-0.1, -0.1, 0.1, 0.1]", "mesh.patch.0.size=0.02",
                          "support.0.on='base'", "support.0.ux=0.0"])
    assert raw["mesh"]["patch"] == [{"box": [-0.1, -0.1, 0.1, 0.1], "size": 0.02}]
    assert raw["support"] == [{"on": "base", "ux": 0.0}]
    apply_overrides(raw, ["analysis.steps=3"])  # a missing plain table stays a table
    assert raw["analysis"] == {"steps": 3}


def test_an_index_beyond_the_end_of_a_missing_array_is_an_error() -> None:
    with pytest.raises(InputError, match=r"no entry '1' in mesh.patch"):
        apply_overrides({"mesh": {}}, ["mesh.patch.1.size=0.02"])


def test_a_whole_entry_as_an_inline_table_appends_or_replaces() -> None:
    """Before: `load.1={...}` was refused with "name an entry of load ... before the
    key", though it named entry 1."""
    raw = {"load": [{"on": "top", "pressure": 1.0}], "body": [{"name": "b", "E": 1.0}]}
    apply_overrides(raw, ['load.1={on="side", total_force=[0.0, -1.0]}',
                          'body.b={name="b", E=2.0, nu=0.3}', 'load.0={on="top", pressure=2.0}'])
    assert raw["load"] == [{"on": "top", "pressure": 2.0},
                           {"on": "side", "total_force": [0.0, -1.0]}]
    assert raw["body"] == [{"name": "b", "E": 2.0, "nu": 0.3}]
    with pytest.raises(InputError, match=r"no entry '5' in load"):
        apply_overrides(raw, ['load.5={on="x"}'])
    with pytest.raises(InputError, match=r"or give a whole entry as an inline table, e.g. "
                                         r"load.2=\{...\}"):
        apply_overrides(raw, ["load.1=3.0"])
