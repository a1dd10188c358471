"""ViNE numeric core: volume → isosurface, colour table, brush index, stroke folding, depth cue, views, display
proxy (spec 000_vine §1.4–2.7, checklist items 1–3, 8–9, 13–17, 24, 26–27).

Takes and returns arrays and never imports pyvista/vtk, any UI or the documents: the labels document (the
session: labels, history, command log, bundles) is :class:`plantvr.documents.labels.Segmentation`, the view
:mod:`plantvr.view.vine_layers` (the layers :class:`plantvr.View` draws it with).
"""
from plantvr.vine.colors import DEFAULT_PALETTE, ColorTable
from plantvr.vine.depthcue import coarse_hull, depth_cue_colors, depth_factor, hull_distances, inside_hull
from plantvr.vine.fill import MeshGraph, flood_region, label_components, mesh_graph
from plantvr.vine.index import GridIndex, KDTreeIndex, ball_query_brute
from plantvr.vine.isosurface import Surface, extract_isosurface, signed_volume
from plantvr.vine.labelstats import label_mesh, label_table
from plantvr.vine.proxy import DisplayProxy, decimate_with_owner
from plantvr.vine.slices import plane_segments, slice_contours
from plantvr.vine.stamps import merge_stamps
from plantvr.vine.synth import (
    COMPONENTS,
    FlowerHead,
    synth_flowerhead,
    synth_vessels,
    tile_mesh,
    vertex_labels_from_volume,
)
from plantvr.vine.views import SavedView, load_view, save_view, world_to_model
from plantvr.vine.volume import downsample2, histogram, save_volume, suggest_level

__all__ = [
    "COMPONENTS",
    "DEFAULT_PALETTE",
    "ColorTable",
    "DisplayProxy",
    "FlowerHead",
    "GridIndex",
    "KDTreeIndex",
    "MeshGraph",
    "SavedView",
    "Surface",
    "ball_query_brute",
    "coarse_hull",
    "decimate_with_owner",
    "depth_cue_colors",
    "depth_factor",
    "downsample2",
    "extract_isosurface",
    "flood_region",
    "histogram",
    "hull_distances",
    "inside_hull",
    "label_components",
    "label_mesh",
    "label_table",
    "load_view",
    "merge_stamps",
    "mesh_graph",
    "plane_segments",
    "save_view",
    "save_volume",
    "signed_volume",
    "slice_contours",
    "suggest_level",
    "synth_flowerhead",
    "synth_vessels",
    "tile_mesh",
    "vertex_labels_from_volume",
    "world_to_model",
]
