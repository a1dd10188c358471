"""Adapters: numeric library filters the cores do not import (VTK), behind small functions (issue 21).

Layer: above the numeric cores, below the documents (pyproject's import-linter ``layers`` contract); an adapter
module may import VTK and a core, never a document, io, view, ui or vr.
"""
