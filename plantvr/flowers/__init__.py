"""Dense inflorescences (spec 002_inflorescences §2–§5, checklist §8.1 C1–C14, C17, C20–C25, C28).

Sub-modules
-----------
phyllotaxis
    Ridley/Vogel placement on receptacles of revolution (Eqs. 5.1–5.2), centripetal fractionation,
    parastichy counting, stage from primordium age.
dynamic
    Dynamic phyllotaxis on a growing receptacle: centripetal/divergent fractionation and segregation with
    area bookkeeping A_in + ΣA_i + A_out (V30, V31).
hierarchical
    Hierarchical patterns: elements that become meristems of their own, Hofmeister rule (V32).
scn
    SCN scene and RBA placement-series files (§3.8), lossless round trip.
fate
    Floret fate by the cone test (Eqs. 6.1–6.2, ERRATUM A.4) and distance thresholds.
floret
    Floret editor core: clamped B-spline petals, n-fold corolla, fusion and welding, intrinsic key-pose
    blending, Eq. 2.1 repolygonization, OBJ sequence I/O; the ``FLORET`` parameter table (the state of
    :class:`plantvr.documents.inflorescence.InflorescenceDocument`).
pbd
    Position-based dynamics: distance and signed dihedral bending constraints (numba + numpy twins).
ccd
    Continuous collision detection: spatial-hash broad phase, coplanarity cubics, root finding,
    vertex-triangle and edge-edge collision constraints, static intersection check (its numba kernels are in
    ``_ccd_kernels``).
composer
    Algorithm 1 (the Floral Canopy Composer loop) over instanced floret animations; its settings are the
    ``SOLVER`` parameter table.
models
    The seven example models of §6.2: sunflower-like (34 rays), Gaillardia-like (21 rays), dahlia (300 broad,
    rolled, scale-like florets on a ball), Dyssodia (1 + 5 heads, Fig. 6.4b), yarrow (corymb of heads, Fig. 6.4a), Orlaya (two-level
    umbel, Fig. 6.4c) and a lilac-like panicle.
smoothing
    Loop-subdivision post-process with collision resolution (§3.9, C14), reusing plantvr.subdivision.
branching
    Florets-first extended Rodkaew branching for corymbs and (compound) umbels, pipe widths, tube meshes.
"""
from plantvr.flowers.dynamic import DynamicFrame, DynamicPhyllotaxis  # noqa: F401  (§4.3 dynamic phyllotaxis)
from plantvr.flowers.fate import cone_dmin, floret_fate, ray_florets  # noqa: F401
from plantvr.flowers.hierarchical import (  # noqa: F401  (§4.4 hierarchical patterns)
    HierarchicalPhyllotaxis,
    LevelSpec,
    hofmeister_angles,
)
from plantvr.flowers.phyllotaxis import (  # noqa: F401
    GOLDEN_ANGLE_DEG,
    Receptacle,
    centripetal_fractionation,
    cone_receptacle,
    disc_receptacle,
    dome_receptacle,
    floret_stage,
    parastichy_numbers,
    place_on_receptacle,
    receptacle_from_profile,
    ridley_placement,
    vogel_disc,
)
