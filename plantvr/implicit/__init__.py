"""Implicit crown envelopes, point distributions and the command language's parser (spec 003_implicit_sca; C-1 to
C-22). The state the language builds is :class:`plantvr.documents.crown.CrownDocument`.

Numeric core: numpy in, numpy out; no UI imports. Space colonization itself lives in ``plantvr.growth.colonize``;
:func:`grow_in_crown` feeds it the crown's attraction points.
"""
from .band import FieldCache, sample_band
from .blobtree import (Blend, CircleSkeleton, Difference, Difference2, Intersection, Node, PointSkeleton,
                       PolylineSkeleton, Primitive, SegmentSkeleton, TransformNode, Union, polyline, segment, sphere,
                       torus)
from .commands import CommandError, parse_script
from .crown import default_roots, grow_in_crown, pipe_radii
from .fields import ISO, blinn, wyvill, wyvill_derivative
from .mesh_sampling import face_cdf, sample_mesh_near
from .pointsets import PointSet, densify, load_point_set, read_props, save_point_set, thin, write_props
from .polygonize import polygonize, sample_grid
from .sampling import (LaneKernel, cluster_kernel, custom_kernel, field_pdf, icdf_step_1d, lane_in_node, lane_sample,
                       poisson_kernel, rejection_sample, sample_inside, sample_step_pdf, step_cdf)
from .skinning import Circle2D, Polygon2D, Revolution, Skin, SkinPath, sweep
from .variational import Variational
from .warps import Warp, bend, taper, twist

__all__ = [
    "Blend", "Circle2D", "CircleSkeleton", "CommandError", "Difference", "Difference2",
    "FieldCache", "ISO", "Intersection", "LaneKernel", "Node", "PointSet", "PointSkeleton", "Polygon2D",
    "PolylineSkeleton", "Primitive", "Revolution", "SegmentSkeleton", "Skin", "SkinPath", "TransformNode", "Union",
    "Variational", "Warp", "bend", "blinn", "cluster_kernel", "custom_kernel", "default_roots", "densify", "face_cdf", "field_pdf",
    "grow_in_crown", "icdf_step_1d", "lane_in_node", "lane_sample", "load_point_set", "parse_script", "pipe_radii",
    "poisson_kernel", "polygonize", "polyline", "read_props", "rejection_sample", "sample_band", "sample_grid",
    "sample_inside", "sample_mesh_near", "sample_step_pdf", "save_point_set", "segment", "sphere", "step_cdf", "sweep",
    "taper", "thin", "torus", "twist", "warps", "wyvill", "wyvill_derivative", "write_props",
]
from . import warps  # noqa: E402
