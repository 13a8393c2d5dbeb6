"""Every script's --help opens with the whole first paragraph of its docstring: before, 30
of them showed only its first line, most cut mid-sentence (bench_mortar.py: "... (and, on
request, mortar-smooth or")."""

from __future__ import annotations

import ast

import pytest
from support import ROOT

SCRIPTS = sorted((ROOT / "scripts").glob("*.py"))


def _description(path):
    """The `description=` expression given to argparse.ArgumentParser in `path`, or None."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "ArgumentParser":
            for kw in node.keywords:
                if kw.arg == "description":
                    return kw.value
    return None


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.name for p in SCRIPTS])
def test_the_help_opens_with_the_docstrings_first_paragraph(path):
    expr = _description(path)
    if expr is None:
        pytest.skip("no argparse description")
    doc = ast.get_docstring(ast.parse(path.read_text()), clean=False)
    try:  # what argparse receives, with __doc__ bound to the module's docstring
        text = eval(compile(ast.Expression(expr), str(path), "eval"), {"__doc__": doc})
    except NameError:
        pytest.skip("description built from other names")
    first = doc.split("\n\n")[0]
    assert " ".join(text.split()).startswith(" ".join(first.split())), path.name
