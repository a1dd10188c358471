"""Every benchmark in benchmarks/ runs at reduced size (``--quick``) in CI and prints its figures."""
import importlib.util
import os
from pathlib import Path

import pytest

BENCH = sorted((Path(__file__).resolve().parent.parent / "benchmarks").glob("*.py"))


@pytest.mark.slow
@pytest.mark.parametrize("path", BENCH, ids=[p.stem for p in BENCH])
def test_benchmark_quick(path, capsys):
    if os.environ.get("PLANTVR_SKIP_BENCH"):
        pytest.skip("PLANTVR_SKIP_BENCH set")
    spec = importlib.util.spec_from_file_location(f"bench_{path.stem}", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod.main(["--quick"])
    assert capsys.readouterr().out.strip()
