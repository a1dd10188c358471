"""Issue 20 for the rest of the inflorescence entry points (composer, branching, hierarchical, dynamic, fate,
smoothing, models, the pbd helpers): every public call checks its input at the door with a ValueError naming
the parameter, a rejected command leaves the object unchanged, and no kernel loop can hang or index out of
bounds on input that passed the door."""
from __future__ import annotations

import io
import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr.flowers import branching, composer, dynamic, fate, hierarchical, models, pbd, smoothing
from plantvr.flowers.dynamic import DynamicPhyllotaxis
from plantvr.flowers.hierarchical import HierarchicalPhyllotaxis, LevelSpec

BAD = [np.nan, np.inf, -np.inf, 1e300, 1e19, 10**12, -5, 0, 1e-20, "x", None, [], True]
BAD_INT = [np.nan, np.inf, 1e300, 10**12, -5, -1, 0.5, "3", None, 2**70]
BAD_ARRAY = [np.full((3, 3), np.nan), np.full((3, 3), 1e300), np.zeros((3, 2)), np.zeros((0, 3)), "abc", None,
             [[1, 2], [3]], np.zeros((3, 3), dtype=object), np.ones((2, 2, 3))]
FUZZ = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _patch(n=3):
    x, faces = pbd.cloth_patch(n, n, spacing=0.1)
    return np.ascontiguousarray(x), faces


@pytest.fixture(scope="module")
def ftype():
    x, faces = _patch()
    return composer.FloretType(faces, np.stack([x, x * 1.2 + [0, 0, 0.01]]), [0, 1, 2])


@pytest.fixture(scope="module")
def canopy(ftype):
    return composer.Canopy([ftype], [0, 0], [[0, 0, 0], [1.0, 0, 0]], [[0, 0, 1.0]] * 2, [[1.0, 0, 0]] * 2,
                           [1.0, 1.0])


class _StatePickler(pickle.Pickler):
    """Pickles an object's whole state; user functions (not picklable when local) stand in by identity."""

    def reducer_override(self, obj):
        if callable(obj) and getattr(obj, "__qualname__", "").count("<locals>"):
            return str, (f"fn{id(obj)}",)
        return NotImplemented


def _state(obj) -> bytes:
    buf = io.BytesIO()
    _StatePickler(buf).dump(obj.__dict__)
    return buf.getvalue()


def _fill(shape, bad):
    """An array of ``shape`` full of a scalar bad value, or the bad non-scalar itself."""
    if isinstance(bad, (float, int, str)):
        out = np.empty(shape, dtype=object)
        out[...] = bad
        return out
    return bad


# ---------------------------------------------------------------------------------- reproduced first
def test_huge_rest_angle_is_refused_instead_of_hanging_the_kernel():
    """rest_phi = 1e300 made the kernel's (-pi, pi] wrapping loop spin forever (c - 2 pi == c)."""
    x, faces = _patch()
    e, q = pbd.mesh_edges(faces), pbd.bend_quads(faces)
    with pytest.raises(ValueError, match="rest_phi"):
        pbd.solve_internal(x.copy(), np.ones(len(x)), e, pbd.edge_lengths(x, e), q, np.full(len(q), 1e300))
    p = x.copy()
    p[0, 0] = 1e300
    with pytest.raises(ValueError, match="p "):
        pbd.solve_internal(p, np.ones(len(x)), e, pbd.edge_lengths(x, e), q, np.zeros(len(q)))


def test_used_up_meristem_does_not_spin_through_production_rounds():
    """A used-up centripetal meristem stepped by 1e9 looped 1e9 idle rounds; a tiny dt_prod, 1e20."""
    d = DynamicPhyllotaxis(max_primordia=5, dt_prod=0.1)
    d.step(1.0)
    assert d.n == 5
    d.step(1e9)                         # used up: returns at once
    assert d.n == 5
    with pytest.raises(ValueError, match="dt"):   # still producing: 1e9 rounds are refused at the door
        DynamicPhyllotaxis().step(1e9)
    d = DynamicPhyllotaxis(dt_prod=1e-12, inner_area=1e6)
    before = _state(d)
    with pytest.raises(ValueError, match="dt"):
        d.step(1.0)
    assert _state(d) == before


def test_index_tables_outside_their_meshes_are_refused():
    x, faces = _patch()
    with pytest.raises(ValueError, match="edges"):
        pbd.edge_lengths(x, pbd.mesh_edges(faces) + 100)
    with pytest.raises(ValueError, match="quads"):
        pbd.signed_dihedrals(x, pbd.bend_quads(faces) + 100)
    with pytest.raises(ValueError, match="fixed"):
        composer.FloretType(faces, x[None], [99])       # was accepted; Canopy then failed inside numpy
    tree = branching.BranchTree(np.zeros((2, 3)), np.array([-1, 0]), np.zeros(2, np.int64), np.array([1]), [])
    with pytest.raises(ValueError, match="parent"):
        branching.BranchTree(tree.pos, np.array([-1, 7]), tree.branch_id, tree.tips, [])
    with pytest.raises(ValueError, match="tips"):
        branching.BranchTree(tree.pos, tree.parent, tree.branch_id, np.array([5]), [])
    with pytest.raises(ValueError, match="faces"):
        smoothing.midpoint_subdivide(x, faces + 100)


def test_degenerate_placements_are_refused(ftype):
    with pytest.raises(ValueError, match="up"):
        composer.Canopy([ftype], [0], [[0, 0, 0]], [[0, 0, 0]], [[1, 0, 0]], [1.0])   # gave NaN frames
    with pytest.raises(ValueError, match="right"):
        composer.Canopy([ftype], [0], [[0, 0, 0]], [[0, 0, 1.0]], [[0, 0, 2.0]], [1.0])
    with pytest.raises(ValueError, match="kind"):
        composer.Canopy([ftype], [], np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), [])
    with pytest.raises(ValueError, match="types"):
        composer.Canopy(["x"], [0], [[0, 0, 0]], [[0, 0, 1.0]], [[1, 0, 0]], [1.0])


def test_user_functions_are_checked():
    with pytest.raises(ValueError, match="w_b"):
        branching.rodkaew([[0, 0, 1.0]], [0, 0, 0], w_b="x")
    with pytest.raises(ValueError, match="w_b"):
        branching.rodkaew([[0, 0, 1.0], [0.1, 0, 1.0]], [0, 0, 0], w_b=lambda d: np.nan)
    with pytest.raises(ValueError, match="primordium_area"):
        LevelSpec(primordium_area=np.nan)              # was only found when a child meristem first grew
    with pytest.raises(ValueError, match="inner_rate"):
        DynamicPhyllotaxis(inner_rate=lambda t: "x").step(1.0)


def test_failing_user_function_leaves_the_heads_unchanged():
    broken = {"on": False}

    def area(age):
        if broken["on"]:
            raise ZeroDivisionError("user bug")
        return 0.05 + 0.0 * np.asarray(age)

    d = DynamicPhyllotaxis(primordium_area=area, dt_prod=0.5)
    d.run(3, 1.0)
    h = HierarchicalPhyllotaxis([LevelSpec(meristem_area=0.06, inner_rate=0.05, primordium_area=area),
                                 LevelSpec(primordium_area=area)])
    h.run(3, 1.0)
    before_d, before_h = _state(d), _state(h)
    broken["on"] = True
    with pytest.raises(ZeroDivisionError):
        d.step(1.0)
    with pytest.raises(ZeroDivisionError):
        h.step(1.0)
    assert _state(d) == before_d and _state(h) == before_h
    broken["on"] = False
    assert d.step(1.0).n > 0 and h.florets()["position"].shape[1] == 3


# --------------------------------------------------------------------------------------------- fuzz
@FUZZ
@given(st.sampled_from(BAD_INT))
def test_fuzz_counts(fuzz, bad):
    fuzz.call("branching.corymb", branching.corymb, bad, param="n_florets")
    fuzz.call("branching.compound_umbel", branching.compound_umbel, bad, 3, param="n_umbellets")
    fuzz.call("branching.compound_umbel", branching.compound_umbel, 2, bad, param="florets_per_umbellet")
    fuzz.call("branching.rodkaew", branching.rodkaew, [[0, 0, 1.0]], [0, 0, 0], max_steps=bad, param="max_steps")
    fuzz.call("branching.tube_mesh", branching.tube_mesh, branching.corymb(3), np.ones(1), sides=bad,
              param=("sides", "diameters"))
    fuzz.call("composer.SolverParams", composer.SolverParams, solver_iterations=bad, param="solver_iterations")
    fuzz.call("composer.SolverParams", composer.SolverParams, max_collision_retries=bad,
              param="max_collision_retries")
    fuzz.call("hierarchical.LevelSpec", LevelSpec, max_elements=bad, param="max_elements")
    h = HierarchicalPhyllotaxis([LevelSpec()])
    before = _state(h)
    if isinstance(fuzz.call("HierarchicalPhyllotaxis.run", h.run, bad, 1.0, param="steps"), Exception):
        assert _state(h) == before
    fuzz.call("HierarchicalPhyllotaxis.frame", h.frame, bad, param="i")
    fuzz.call("HierarchicalPhyllotaxis.element_positions", h.element_positions, bad, param="i")
    d = DynamicPhyllotaxis()
    before = _state(d)
    if isinstance(fuzz.call("DynamicPhyllotaxis.run", d.run, bad, 1.0, param="steps"), Exception):
        assert _state(d) == before
    fuzz.call("DynamicPhyllotaxis.override_areas", d.override_areas, [bad], [1.0], param="ids")
    fuzz.call("fate.cone_dmin", fate.cone_dmin, np.random.default_rng(0).random((5, 3)), alpha_deg=30,
              block=bad, param="block")
    x, faces = _patch()
    fuzz.call("smoothing.loop_smooth", smoothing.loop_smooth, x, faces, bad, param="n_iter")
    fuzz.call("pbd.solve_internal", pbd.solve_internal, x.copy(), np.ones(len(x)), np.zeros((0, 2), np.int64),
              np.zeros(0), np.zeros((0, 4), np.int64), np.zeros(0), iterations=bad, param="iterations")
    fuzz.call("FlowerHead.schedule", models.FlowerHead(None, np.zeros(3), np.zeros(3), 0.6).schedule, bad,
              param="n_steps")
    for name, fn, p in (("models.sunflower_head", models.sunflower_head, "n_florets"),
                        ("models.dahlia_head", models.dahlia_head, "n_florets"),
                        ("models.dyssodia_head", models.dyssodia_head, "florets_per_head"),
                        ("models.yarrow_corymb", models.yarrow_corymb, "n_heads"),
                        ("models.orlaya_umbel", models.orlaya_umbel, "n_umbellets"),
                        ("models.lilac_panicle", models.lilac_panicle, "n_pairs")):
        out = fuzz.call(name, fn, bad, param=p)
        assert isinstance(out, Exception), (name, bad)
    fuzz.call("models.disc_floret", models.disc_floret, n_fold=bad, param="n_fold")
    fuzz.call("models.disc_floret", models.disc_floret, n_frames=bad, param="n_frames")


@FUZZ
@given(st.sampled_from(BAD))
def test_fuzz_values(fuzz, bad):
    fuzz.call("composer.SolverParams", composer.SolverParams, spacing=bad, param="spacing")
    fuzz.call("composer.SolverParams", composer.SolverParams, k_bend=bad, param="k_bend")
    fuzz.call("composer.SolverParams", composer.SolverParams, omega=bad, param="omega")
    fuzz.call("composer.SolverParams", composer.SolverParams, method=bad, param="method")
    tree = branching.corymb(4)
    for kw in ("w_a", "w_h", "delta", "merge_dist", "search_radius"):
        out = fuzz.call("branching.rodkaew", branching.rodkaew, [[0, 0, 1.0], [0.2, 0, 1.0]], [0, 0, 0],
                        max_steps=1000, param=(kw, "w_a + w_h", "max_steps"), **{kw: bad})
        if not isinstance(out, Exception):
            assert np.all(np.isfinite(out.pos)) and np.all(out.depth_to_root() >= 0)
    fuzz.call("branching.rodkaew", branching.rodkaew, [[0, 0, 1.0]], [0, 0, bad], param="base")
    fuzz.call("branching.rodkaew", branching.rodkaew, [[0, 0, 1.0]], [0, 0, 0], emergence=[bad],
              param="emergence")
    fuzz.call("branching.rodkaew", branching.rodkaew, [[0, 0, 1.0]], [0, 0, 0], initial_direction=bad,
              param="initial_direction")
    fuzz.call("branching.linear_wb", branching.linear_wb, bad, param="radius")
    fuzz.call("branching.corymb", branching.corymb, 3, radius=bad, param="radius")
    fuzz.call("branching.corymb", branching.corymb, 3, emergence_interval=bad, param="emergence_interval")
    for kw in ("radius", "umbellet_radius", "height", "umbellet_height", "delta"):
        out = fuzz.call("branching.compound_umbel", branching.compound_umbel, 2, 2, param=(kw, "max_steps"),
                        **{kw: bad})
        if not isinstance(out, Exception):
            assert np.all(np.isfinite(out[0].pos))
    out = fuzz.call("branching.pipe_widths", branching.pipe_widths, tree, tip_diameter=bad, param="tip_diameter")
    if not isinstance(out, Exception):
        assert np.all(np.isfinite(out))
    fuzz.call("branching.pipe_widths", branching.pipe_widths, tree, p=bad, param="p")
    fuzz.call("branching.pipe_widths", branching.pipe_widths, bad, param="tree")
    out = fuzz.call("branching.scale_tree", branching.scale_tree, tree, bad, param="scale")
    if not isinstance(out, Exception):
        assert np.all(np.isfinite(out.pos))
    fuzz.call("branching.scale_tree", branching.scale_tree, tree, [1, bad], param="scale")
    fuzz.call("branching.scale_tree", branching.scale_tree, tree, 2.0, about=[bad, 0, 0], param="about")
    fuzz.call("branching.tube_mesh", branching.tube_mesh, tree, _fill(tree.n_nodes, bad), param="diameters")
    fuzz.call("branching.BranchTree", branching.BranchTree, _fill((2, 3), bad), [-1, 0], [0, 0], [1], [],
              param="pos")
    fuzz.call("branching.BranchTree", branching.BranchTree, np.zeros((2, 3)), [-1, bad], [0, 0], [1], [],
              param="parent")
    fuzz.call("branching.BranchTree", branching.BranchTree, np.zeros((2, 3)), [-1, 0], [0, 0], [bad], [],
              param="tips")
    for kw in ("inner_area", "divergence_deg", "alpha0_deg"):
        fuzz.call("HierarchicalPhyllotaxis", HierarchicalPhyllotaxis, [LevelSpec()], param=kw, **{kw: bad})
    fuzz.call("HierarchicalPhyllotaxis", HierarchicalPhyllotaxis, bad, param="levels")
    for kw in ("primordium_area", "inner_rate", "outer_rate", "threshold", "meristem_area", "dt_prod", "packing",
               "mode", "profile"):
        fuzz.call("hierarchical.LevelSpec", LevelSpec, param=kw, **{kw: bad})
    fuzz.call("hierarchical.hofmeister_angles", hierarchical.hofmeister_angles, bad, param="pattern")
    h = HierarchicalPhyllotaxis([LevelSpec(meristem_area=0.06, inner_rate=0.05), LevelSpec()])
    h.run(2, 1.0)
    before = _state(h)
    out = fuzz.call("HierarchicalPhyllotaxis.step", h.step, bad, param="dt")
    if isinstance(out, Exception):
        assert _state(h) == before
    h.step(1.0)
    assert np.all(np.isfinite(h.florets()["position"]))
    d = DynamicPhyllotaxis(mode="segregation", inner_area=0.04, inner_rate=0.03, max_primordia=300)
    d.run(3, 1.0)
    before = _state(d)
    if isinstance(fuzz.call("DynamicPhyllotaxis.step", d.step, bad, param="dt"), Exception):
        assert _state(d) == before
    if isinstance(fuzz.call("DynamicPhyllotaxis.override_areas", d.override_areas, [0], [bad], param="areas"),
                  Exception):
        assert _state(d) == before
    fuzz.call("DynamicPhyllotaxis.override_areas", d.override_areas, bad, bad, param=("ids", "areas"))
    fr = d.step(0.5)
    assert np.all(np.isfinite(fr.position))
    P = np.random.default_rng(1).random((6, 3))
    fuzz.call("fate.cone_dmin", fate.cone_dmin, P, alpha_deg=bad, param="alpha_deg")
    fuzz.call("fate.cone_dmin", fate.cone_dmin, P, alpha_deg=30, centre=[bad, 0, 0], param="centre")
    fuzz.call("fate.ray_florets", fate.ray_florets, P, alpha_deg=bad, param="alpha_deg")
    fuzz.call("fate.floret_fate", fate.floret_fate, np.ones(3), th_a=bad, param="th_a")
    fuzz.call("fate.floret_fate", fate.floret_fate, np.ones(3), th_a=0.5, th_b=bad, param="th_b")
    fuzz.call("fate.floret_fate", fate.floret_fate, [bad], param="d_min")
    fuzz.call("FlowerHead.schedule", models.FlowerHead(None, np.zeros(3), np.zeros(3), 0.6).schedule, 3,
              t_end=bad, param="t_end")
    for name, fn, kw in (("models.disc_floret", models.disc_floret, "open_deg"),
                         ("models.disc_floret", models.disc_floret, "detail"),
                         ("models.ray_floret", models.ray_floret, "length"),
                         ("models.ray_floret", models.ray_floret, "open_deg"),
                         ("models.quill_floret", models.quill_floret, "incurve_deg"),
                         ("models.dahlia_floret", models.dahlia_floret, "roll_deg"),
                         ("models.dahlia_floret", models.dahlia_floret, "width")):
        out = fuzz.call(name, fn, param=kw, **{kw: bad})
        if not isinstance(out, Exception):
            assert np.all(np.isfinite(out.frames)) and len(out.faces)


@settings(FUZZ, max_examples=20)
@given(st.sampled_from(BAD), st.sampled_from(["sunflower_head", "gaillardia_head", "dahlia_head",
                                               "dyssodia_head", "yarrow_corymb", "orlaya_umbel", "lilac_panicle"]))
def test_fuzz_model_settings_rejected_at_the_door(fuzz, bad, which):
    kw = {"sunflower_head": ("alpha_deg", "radius"), "gaillardia_head": ("alpha_deg", "radius"),
          "dahlia_head": ("radius", "open_deg"), "dyssodia_head": ("head_radius", "ring", "alpha_deg", "th_b"),
          "yarrow_corymb": ("head_radius", "head_spacing", "height", "th_a"),
          "orlaya_umbel": ("scale", "alpha_deg", "th_a"), "lilac_panicle": ("height", "branch_length", "cyme")}
    small = {"sunflower_head": (5,), "gaillardia_head": (5,), "dahlia_head": (5,), "dyssodia_head": (4,),
             "yarrow_corymb": (2, 3), "orlaya_umbel": (2, 3), "lilac_panicle": (1,)}[which]
    fn = getattr(models, which)
    for k in kw[which]:
        out = fuzz.call(f"models.{which}", fn, *small, param=k, **{k: bad, "detail": 0.1, "n_frames": 2})
        if not isinstance(out, Exception):     # an accepted value makes a real head
            assert np.all(np.isfinite(out.canopy.position)) and out.canopy.n_instances > 0


@FUZZ
@given(st.sampled_from(BAD_ARRAY + BAD), st.sampled_from(["position", "up", "right", "scale", "kind", "types"]))
def test_fuzz_canopy(fuzz, ftype, bad, which):
    args = {"types": [ftype], "kind": [0, 0], "position": [[0, 0, 0], [1.0, 0, 0]], "up": [[0, 0, 1.0]] * 2,
            "right": [[1.0, 0, 0]] * 2, "scale": [1.0, 1.0]}
    args[which] = bad
    out = fuzz.call("composer.Canopy", composer.Canopy, param=which, **args)
    if not isinstance(out, Exception):
        x = out.initial_positions(np.zeros(out.n_instances))
        assert np.all(np.isfinite(x))


@FUZZ
@given(st.sampled_from(BAD_ARRAY + BAD), st.sampled_from(["faces", "frames", "fixed"]))
def test_fuzz_floret_type(fuzz, bad, which):
    x, faces = _patch()
    args = {"faces": faces, "frames": np.stack([x, x]), "fixed": [0]}
    args[which] = bad
    out = fuzz.call("composer.FloretType", composer.FloretType, param=which, **args)
    if not isinstance(out, Exception):
        assert np.all(np.isfinite(out.at(0.5)[2]))
        fuzz.call("FloretType.at", out.at, np.nan, param="stage")


@FUZZ
@given(st.sampled_from(BAD_ARRAY + BAD), st.sampled_from(["x", "stages", "prev", "params", "canopy", "backend"]))
def test_fuzz_step_and_grow(fuzz, canopy, bad, which):
    x0 = canopy.initial_positions(np.zeros(2))
    snap = (x0.copy(), canopy.faces.copy(), canopy.w.copy())
    args = {"canopy": canopy, "x": x0, "stages": np.full(2, 0.5), "params": composer.SolverParams(
        solver_iterations=2, max_collision_retries=2), "prev_stages": np.zeros(2), "backend": "numba"}
    key = {"prev": "prev_stages"}.get(which, which)
    if which == "x" and isinstance(bad, np.ndarray) and bad.shape == (3, 3):
        bad = np.resize(bad, x0.shape)               # right shape, bad values
    args[key] = bad
    fuzz.call("composer.step", composer.step, args.pop("canopy"), args.pop("x"), args.pop("stages"),
              args.pop("params"), param=key, **args)
    assert np.array_equal(x0, snap[0]) and np.array_equal(canopy.w, snap[2])
    S = np.array([[0.0, 0.0], [0.5, 0.5]])
    if which in ("stages", "x"):
        S = S.astype(object)
        S[1, 0] = bad if isinstance(bad, (float, int, str, type(None))) else np.nan
        fuzz.call("composer.grow", composer.grow, canopy, S, composer.SolverParams(solver_iterations=2),
                  param="stages_per_step")
    fuzz.call("composer.grow", composer.grow, canopy, np.zeros((2, 2)), prediction=bad, param="prediction")
    fuzz.call("composer.grow", composer.grow, canopy, np.zeros((2, 2)), callback=5 if isinstance(bad, np.ndarray) else bad,
              param="callback")
    fuzz.call("composer.grow", composer.grow, canopy, np.zeros((2, 2)), sanity_every=bad, param="sanity_every")
    x, _ = composer.step(canopy, x0, np.full(2, 0.5), composer.SolverParams(solver_iterations=2))
    assert np.all(np.isfinite(x))


@FUZZ
@given(st.sampled_from(BAD_ARRAY + BAD), st.sampled_from(["edges", "quads", "x", "rest_len", "rest_phi", "w"]))
def test_fuzz_pbd_helpers(fuzz, bad, which):
    x, faces = _patch()
    e, q = pbd.mesh_edges(faces), pbd.bend_quads(faces)
    if which in ("edges", "quads", "x"):
        fuzz.call("pbd.edge_lengths", pbd.edge_lengths, bad if which == "x" else x, bad if which == "edges" else e,
                  param=which)
        fuzz.call("pbd.signed_dihedrals", pbd.signed_dihedrals, bad if which == "x" else x,
                  bad if which == "quads" else q, param=which)
        fuzz.call("pbd.mesh_edges", pbd.mesh_edges, bad, param="faces")
        fuzz.call("pbd.bend_quads", pbd.bend_quads, bad, param="faces")
        fuzz.call("pbd.dihedral_gradient", pbd.dihedral_gradient, bad, x[1], x[2], x[3], param="p1")
        return
    args = {"w": np.ones(len(x)), "rest_len": pbd.edge_lengths(x, e), "rest_phi": np.zeros(len(q))}
    args[which] = _fill(len(args[which]), bad)
    p = x.copy()
    out = fuzz.call("pbd.solve_internal", pbd.solve_internal, p, args["w"], e, args["rest_len"], q,
                    args["rest_phi"], iterations=3, param=which)
    if isinstance(out, Exception):
        assert np.array_equal(p, x)                 # refused before the in-place update
    else:
        assert np.all(np.isfinite(out))


@FUZZ
@given(st.sampled_from(BAD_ARRAY + BAD), st.sampled_from(["vertices", "faces", "fixed", "w", "p", "params",
                                                          "pin", "boundary_rule", "stats"]))
def test_fuzz_smoothing(fuzz, bad, which):
    x, faces = _patch()
    if which in ("vertices", "faces"):
        args = [bad, faces] if which == "vertices" else [x, bad]
        fuzz.call("smoothing.midpoint_subdivide", smoothing.midpoint_subdivide, *args, param=which)
        fuzz.call("smoothing.loop_smooth", smoothing.loop_smooth, *args, 1, param=which)
    elif which in ("w", "p"):
        args = {"x0": x, "p": x + [0, 0, 0.01], "faces": faces, "w": np.ones(len(x))}
        args[which] = bad
        fuzz.call("smoothing.resolve_collisions", smoothing.resolve_collisions, param=which, **args)
    else:
        out = fuzz.call("smoothing.loop_smooth", smoothing.loop_smooth, x, faces, 1, param=which, **{which: bad})
        if not isinstance(out, Exception):
            assert np.all(np.isfinite(out[0])) and len(out[1]) == 4 * len(faces)


def test_smoothing_face_count_is_bounded():
    x, faces = _patch(40)
    faces = np.tile(faces, (10, 1))                      # 30k faces x 4**6 would be 125 M faces
    with pytest.raises(ValueError, match="n_iter"):
        smoothing.loop_smooth(x, faces, 6)


def test_cone_dmin_blocks_are_memory_bounded_and_unchanged():
    P = np.random.default_rng(2).random((300, 3))
    a = fate.cone_dmin(P, alpha_deg=40.0)
    b = fate.cone_dmin(P, alpha_deg=40.0, block=7)
    assert np.array_equal(a, b)
    assert fate._MAX_BLOCK_PAIRS // 300 >= 1


def test_dynamic_module_constants_bound_the_loops():
    assert dynamic.MAX_ROUNDS <= 10**8 and hierarchical.MAX_LEVELS <= 64
