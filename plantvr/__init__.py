"""PlantVR: notebook-centric plant modelling and plant-anatomy segmentation.

The one shared object is :class:`plantvr.Model` (Tree Wand growth, spec 000_treewand);
:class:`plantvr.View` renders it with pyvista/trame. Sub-packages hold the numeric cores.
"""
from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

_LAZY = {"Model": "plantvr.documents.treewand", "View": "plantvr.view"}


def __getattr__(name: str) -> Any:  # lazy: importing plantvr must not start VTK
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'plantvr' has no attribute {name!r}")


__all__ = ["Model", "View", "__version__"]
