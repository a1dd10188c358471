"""Tree Wand growth engine (spec 000_treewand §1–§2): tree SoA, markers, assignment, light, vigor, lengths.

Headless: everything here runs on numpy arrays from a script; :class:`plantvr.Model` adds traits and threads.
"""
from .engine import GrowthEngine, StepStats
from .tree import BUD, NO_SLOT, Tree

__all__ = ["GrowthEngine", "StepStats", "Tree", "BUD", "NO_SLOT"]
