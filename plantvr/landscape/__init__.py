"""Landscapes (spec 004_treesketch §3): terrain height field, tree placement, forests grown tree by tree on dask."""
from .distribution import clustering_kernel, inhibitory_kernel, ripley_k
from .forest import Forest, crown_regions, grow_forest
from .placement import poisson_disc
from .terrain import heightfield, sample_height

__all__ = ["Forest", "clustering_kernel", "crown_regions", "grow_forest", "heightfield", "inhibitory_kernel", "poisson_disc",
           "ripley_k", "sample_height"]
