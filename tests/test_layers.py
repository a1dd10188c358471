"""The import contracts (import-linter, configured in pyproject.toml; issue 21): cli > ui > view | vr > io >
documents > adapters > numeric cores > base, no import cycles at any package level, and cores that import no UI,
VTK or matplotlib."""
import shutil
import subprocess
from pathlib import Path

import pytest


def test_layers_no_cycles_and_cores_without_ui():
    exe = shutil.which("lint-imports")
    if exe is None:
        pytest.skip("import-linter not installed")
    root = Path(__file__).resolve().parent.parent
    res = subprocess.run([exe], cwd=root, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-2000:]
    assert "0 broken" in res.stdout and "3 kept" in res.stdout
