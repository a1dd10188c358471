"""Every dotted ``plantvr...`` name the README shows in backticks resolves (issue 32: the README named
``plantvr.documents.ForestDocument``, which did not import)."""
import importlib
import re
from pathlib import Path

import pytest

README = (Path(__file__).resolve().parent.parent / "README.md").read_text()
NAMES = sorted({m for m in re.findall(r"`(plantvr(?:\.[A-Za-z_][A-Za-z0-9_]*)+)", README)})


def _resolve(name: str):
    parts = name.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for attr in parts[cut:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(name)


def test_readme_names_some():
    assert len(NAMES) > 20


@pytest.mark.parametrize("name", NAMES)
def test_readme_name_resolves(name):
    assert _resolve(name) is not None
