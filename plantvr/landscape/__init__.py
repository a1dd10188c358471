"""Landscapes (spec 004_treesketch §3): terrain height field, tree distribution, forests grown tree by tree on dask
(parameter-record tasks, :mod:`plantvr.scaleout`),
crown-space competition on layered voxels (glTF export: :mod:`plantvr.io.landscape`)."""
from .asymmetry import cell_geometry, landscape_tropism, neighbour_asymmetry
from .crowns import (
           CrownVoxels,
           VoxelSketchEngine,
           claim_segments,
           crown_voxels,
           propagate_layer,
           region_geometry,
)
from .distribution import (
           Distribution,
           Species,
           clustering_kernel,
           distribute,
           inhibitory_kernel,
           ripley_k,
           sample_field,
)
from .forest import FOREST, Forest, crown_regions, grow_forest, regrow_tree, terrain_mesh
from .placement import poisson_disc
from .terrain import brush_height, brush_mask, heightfield, placement_mask, sample_height

__all__ = ["FOREST", "CrownVoxels", "Distribution", "Forest", "Species", "VoxelSketchEngine", "brush_height", "brush_mask",
           "cell_geometry", "claim_segments", "clustering_kernel", "crown_regions", "crown_voxels", "distribute",
           "grow_forest", "heightfield",
           "inhibitory_kernel", "landscape_tropism", "neighbour_asymmetry", "placement_mask", "poisson_disc",
           "propagate_layer", "region_geometry", "regrow_tree", "ripley_k", "sample_field", "sample_height",
           "terrain_mesh"]
