"""The documents: every part's state on one base (:mod:`plantvr.document`; DESIGN "Documents", issue 21).

===========================================  ================================================  ==================
document (KIND)                              what it holds                                     spec
===========================================  ================================================  ==================
:class:`Model` (treewand)                    Tree Wand tree, markers, light grid               000_treewand
:class:`SketchDocument` (treesketch)         TreeSketch tree, strokes, growth timeline          004_treesketch
:class:`Segmentation` (vine)                 ViNE mesh labels, colour table, views             000_vine
:class:`CrownDocument` (crown)               implicit crown surfaces, point sets, grown trees  003_implicit_sca
:class:`InflorescenceDocument` (inflor.)     floret settings, key poses, animation             002_inflorescences
:class:`ForestDocument` (forest)             terrain, competing trees                          004_treesketch §5
:class:`LSystemDocument` (lsystem)           L-Py grammar, derivation step, parameters, seed   issue 23
===========================================  ================================================  ==================
"""
from __future__ import annotations

from .crown import CrownDocument
from .forest import ForestDocument
from .inflorescence import InflorescenceDocument
from .labels import Segmentation
from .lsystem import LSystemDocument
from .treesketch import SketchDocument
from .treewand import Model, Snapshot

__all__ = ["CrownDocument", "ForestDocument", "InflorescenceDocument", "LSystemDocument", "Model", "Segmentation", "SketchDocument",
           "Snapshot"]
