"""The layer contract of STYLE §1: numeric cores import no UI (import-linter, configured in pyproject.toml)."""
import shutil
import subprocess
from pathlib import Path

import pytest


def test_numeric_cores_know_nothing_of_ui():
    exe = shutil.which("lint-imports")
    if exe is None:
        pytest.skip("import-linter not installed")
    root = Path(__file__).resolve().parent.parent
    res = subprocess.run([exe], cwd=root, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-2000:]
    assert "0 broken" in res.stdout
