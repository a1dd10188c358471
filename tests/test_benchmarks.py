"""Every benchmark in benchmarks/ runs at reduced size (``--quick``) in CI and prints its figures."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BENCH = sorted(p for p in (ROOT / "benchmarks").glob("*.py") if not p.name.startswith("_"))  # _common.py: helpers


@pytest.mark.slow
@pytest.mark.parametrize("path", BENCH, ids=[p.stem for p in BENCH])
def test_benchmark_quick(path):
    if os.environ.get("PLANTVR_SKIP_BENCH"):
        pytest.skip("PLANTVR_SKIP_BENCH set")
    res = subprocess.run([sys.executable, str(path), "--quick"], cwd=ROOT, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    assert res.stdout.strip()
