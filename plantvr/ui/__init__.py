"""Notebook widgets and panels over the shared model (spec 000_treewand §4.3–§4.9, §4.11; 000_vine §2.4.1, §2.6).

Every widget is a view of a document (:mod:`plantvr.documents`): it observes the document's traits and change
events and issues its commands; none keeps its own copy of the state. Front-end sources are in the top-level ``widgets/`` folder (``plantvr/_widgets`` in the wheel).
"""
from .architecture import AngleWidget, ArchitecturePanel, GravimorphismEllipse, SchematicTree
from .growth import GrowthControl, GrowthPlot
from .library import LibraryPanel, apply_preset_values, preset_from_tree, tree_svg
from .panels import IconSelector, ParameterPanels, make_control, param_traits
from .strokes import ScenarioPicker
from .triangle import (InfluenceTriangle, barycentric, clamp_to_triangle, point_from_weights,
                       sub_triangle_areas)
from .wheel import ColorWheel, slice_at
from .workbench import Workbench, close_when_headless, live_frontend, workbench

__all__ = ["ColorWheel", "GrowthControl", "GrowthPlot", "IconSelector", "InfluenceTriangle", "ParameterPanels",
           "barycentric", "clamp_to_triangle", "make_control", "param_traits",
           "point_from_weights", "slice_at", "sub_triangle_areas", "explorer",
           "ScenarioPicker",
           "Workbench", "close_when_headless", "live_frontend", "workbench"]


def explorer(model, *, view=None):
    """One layout with the parameter windows, the growth control, the scenario dropdown and (optionally) a
    view widget."""
    import ipywidgets as W  # noqa: PLC0415
    panels, control = ParameterPanels(model), GrowthControl(model)
    right = [control, ScenarioPicker(model)] + ([view] if view is not None else [])
    return W.HBox([panels, W.VBox(right)])


__all__ += ["AngleWidget", "ArchitecturePanel", "GravimorphismEllipse", "LibraryPanel",
            "SchematicTree", "apply_preset_values", "preset_from_tree", "tree_svg"]

from .floret_editor import FloretEditor  # issue 9: spec 002 floret editor

__all__ += ["FloretEditor"]

from .lsystem import LsystemPanel, LsystemWidget  # issue 23: L-system grammars

__all__ += ["LsystemPanel", "LsystemWidget"]
