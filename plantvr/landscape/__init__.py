"""Landscapes (spec 004_treesketch §3): terrain height field, tree placement, forests grown tree by tree on dask."""
from .forest import Forest, grow_forest
from .placement import poisson_disc
from .terrain import heightfield, sample_height

__all__ = ["Forest", "grow_forest", "heightfield", "poisson_disc", "sample_height"]
