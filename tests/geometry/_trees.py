"""Test trees (see plantvr.geometry.synthetic)."""
from plantvr.geometry.synthetic import random_tree

__all__ = ["random_tree"]
