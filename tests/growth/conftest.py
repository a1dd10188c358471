import pytest

from plantvr.growth.engine import GrowthEngine
from plantvr.growth.scenarios import demo_session, run
from plantvr.params import defaults


@pytest.fixture(scope="module")
def grown():
    """A seeded engine after the demo session (about 500 internodes)."""
    e = GrowthEngine(defaults(), rng=0)
    run(e, demo_session(), 60)
    return e


def engine(**params):
    return GrowthEngine({**defaults(), **params}, rng=0)
