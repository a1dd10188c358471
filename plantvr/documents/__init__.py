"""The documents: every part's state on one base (:mod:`plantvr.document`; DESIGN "Documents", issue 21).

============================  ==========================================  =================
document                      what it holds                               spec
============================  ==========================================  =================
:class:`Model` (treewand)     Tree Wand tree, markers, light grid         000_treewand
============================  ==========================================  =================
"""
from __future__ import annotations

from .treewand import Model, Snapshot

__all__ = ["Model", "Snapshot"]
