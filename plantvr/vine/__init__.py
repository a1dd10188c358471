"""ViNE numeric core: volume → isosurface, labels + colour table, brush index, history, depth cue, views,
sessions (spec 000_vine §1.4–2.7, checklist items 1–3, 8–9, 13–17, 24, 26–27).

Never imports pyvista/vtk or any UI; the view lives in :mod:`plantvr.view.segmentation`.
"""
from plantvr.vine.bundle import Bundle, load_bundle, restore_bundle, save_bundle
from plantvr.vine.colors import DEFAULT_PALETTE, ColorTable
from plantvr.vine.depthcue import coarse_hull, depth_cue_colors, depth_factor, hull_distances, inside_hull
from plantvr.vine.fill import MeshGraph, flood_region, label_components, mesh_graph
from plantvr.vine.history import History, LabelEdit
from plantvr.vine.index import GridIndex, KDTreeIndex, ball_query_brute
from plantvr.vine.isosurface import Surface, extract_isosurface, signed_volume
from plantvr.vine.labelstats import export_label_meshes, label_mesh, label_table, plot_label_areas
from plantvr.vine.ply import write_ply
from plantvr.vine.proxy import DisplayProxy, decimate_with_owner
from plantvr.vine.segmentation import Segmentation
from plantvr.vine.slices import plane_segments, slice_contours, slice_figure
from plantvr.vine.synth import (
    COMPONENTS,
    FlowerHead,
    synth_flowerhead,
    synth_vessels,
    tile_mesh,
    vertex_labels_from_volume,
)
from plantvr.vine.views import SavedView, load_view, save_view, world_to_model
from plantvr.vine.volume import downsample2, histogram, load_volume, save_volume, suggest_level

__all__ = [
    "COMPONENTS",
    "DEFAULT_PALETTE",
    "Bundle",
    "ColorTable",
    "DisplayProxy",
    "FlowerHead",
    "GridIndex",
    "History",
    "KDTreeIndex",
    "LabelEdit",
    "MeshGraph",
    "SavedView",
    "Segmentation",
    "Surface",
    "ball_query_brute",
    "coarse_hull",
    "decimate_with_owner",
    "depth_cue_colors",
    "depth_factor",
    "downsample2",
    "export_label_meshes",
    "extract_isosurface",
    "flood_region",
    "histogram",
    "hull_distances",
    "inside_hull",
    "label_components",
    "label_mesh",
    "label_table",
    "load_bundle",
    "load_view",
    "load_volume",
    "mesh_graph",
    "plane_segments",
    "plot_label_areas",
    "restore_bundle",
    "save_bundle",
    "save_view",
    "save_volume",
    "signed_volume",
    "slice_contours",
    "slice_figure",
    "suggest_level",
    "synth_flowerhead",
    "synth_vessels",
    "tile_mesh",
    "vertex_labels_from_volume",
    "world_to_model",
    "write_ply",
]
