"""Test trees (see plantvr.geometry.synthetic)."""
from plantvr.geometry.synthetic import leafy_tree, random_tree

__all__ = ["leafy_tree", "random_tree"]
