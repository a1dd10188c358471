"""Landscapes (spec 004_treesketch §3): terrain height field, tree distribution, forests grown tree by tree on dask."""
from .asymmetry import cell_geometry, landscape_tropism, neighbour_asymmetry
from .distribution import (
           Distribution,
           Species,
           clustering_kernel,
           distribute,
           inhibitory_kernel,
           ripley_k,
           sample_field,
)
from .forest import Forest, crown_regions, grow_forest
from .placement import poisson_disc
from .terrain import brush_height, brush_mask, heightfield, placement_mask, sample_height

__all__ = ["Distribution", "Forest", "Species", "brush_height", "brush_mask", "cell_geometry", "clustering_kernel", "crown_regions", "distribute",
           "grow_forest", "heightfield", "inhibitory_kernel", "landscape_tropism", "neighbour_asymmetry", "placement_mask",
           "poisson_disc", "ripley_k", "sample_field", "sample_height"]
