"""Tree geometry: skeleton, generalized cylinders, LOD, bark UVs, leaves, export (spec 000_treewand §3, §8.1 items 16–22)."""
from .appearance import (
    FruitPlacement,
    contour_sides,
    place_fruit,
    thickest_main_child,
    thickest_path_mesh,
    vigor_leaf_colors,
)
from .leaves import IncrementalLeafMesh, LeafMesh, build_leaves
from .mesh import (
    BranchMesh,
    IncrementalBranchMesh,
    MeshUpdate,
    Segments,
    build_branch_mesh,
    length_estimate,
    lod_level,
    rational_bezier,
    rational_bezier_tangent,
    ring_counts,
    smoothstep,
    transport_frame,
    tree_segments,
    update_branch_mesh,
)

__all__ = ["BranchMesh", "IncrementalBranchMesh", "IncrementalLeafMesh", "LeafMesh", "MeshUpdate", "Segments",
           "build_branch_mesh", "build_leaves", "length_estimate", "lod_level", "rational_bezier",
           "rational_bezier_tangent", "ring_counts", "smoothstep", "transport_frame", "tree_segments",
           "update_branch_mesh"]

__all__ += ["FruitPlacement", "contour_sides", "place_fruit", "thickest_main_child", "thickest_path_mesh",
            "vigor_leaf_colors"]
