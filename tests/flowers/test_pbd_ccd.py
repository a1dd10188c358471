"""Tests for spec 002 §3: PBD constraints (V9–V12), CCD (V16–V21), collision constraints (V22–V23)."""
import numpy as np
import pytest

from plantvr.flowers import _ccd_kernels as K
from plantvr.flowers import ccd, pbd


def _strip(nx=5, ny=8, size=0.1):
    return pbd.cloth_patch(nx, ny, spacing=size)


def _bent_strip(seed, nx, ny, *, noise=0.02, pinned=4, mod=pbd):
    """A strip with jittered heights, perturbed rest lengths and angles and ``pinned`` attached vertices."""
    rng = np.random.default_rng(seed)
    x, f = _strip(nx, ny)
    x[:, 2] += noise * rng.normal(size=len(x))
    e, q = mod.mesh_edges(f), mod.bend_quads(f)
    rl = mod.edge_lengths(x, e) * rng.uniform(0.8, 1.2, len(e))
    rp = mod.signed_dihedrals(x, q) + rng.normal(0, 0.3, len(q))
    w = np.ones(len(x))
    w[:pinned] = 0
    return x, w, e, rl, q, rp


def _two_strips(rng, n, offset):
    """Two n x n strips, the second shifted by ``offset``, and end positions jittered by 0.03."""
    x0, f = _strip(n, n)
    x0 = np.vstack([x0, x0 + offset])
    f = np.vstack([f, f + n * n])
    return x0, f, x0 + rng.normal(0, 0.03, x0.shape)


def _point_through_triangle():
    """Vertex 0 falls from z = 0.37 to -0.63 through the triangle (1, 2, 3) in the z = 0 plane."""
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    return np.array([[1, 2, 3]]), np.vstack([[0.2, 0.2, 0.37], tri]), np.vstack([[0.2, 0.2, -0.63], tri])


def test_cloth_patch_grid_orientation_and_bad_input():
    import trimesh
    x, f = pbd.cloth_patch(4, 3, spacing=0.5)
    assert x.shape == (12, 3) and f.shape == (12, 3) and f.dtype == np.int64
    assert np.array_equal(x[5], [0.5, 1.0, 0.0])                             # vertex i * ny + j
    mesh = trimesh.Trimesh(x, f, process=False)
    assert mesh.area == pytest.approx(1.5 * 1.0, abs=1e-12)
    assert np.allclose(mesh.face_normals, [0, 0, 1])                          # all faces along +z
    assert len(pbd.mesh_edges(f)) == 3 * 3 + 4 * 2 + 3 * 2                    # rows, columns, diagonals
    assert len(pbd.bend_quads(f)) == len(pbd.mesh_edges(f)) - 2 * (3 + 2)     # every interior edge
    assert np.array_equal(pbd.cloth_patch(3)[0], pbd.cloth_patch(3, 3, spacing=0.1)[0])
    with pytest.raises(ValueError, match="nx must be an integer in"):
        pbd.cloth_patch(1)
    with pytest.raises(ValueError, match="spacing must be in"):
        pbd.cloth_patch(3, 3, spacing=0.0)


def test_v9_distance_projection_exact_and_momentum():
    p = np.array([[0.0, 0, 0], [1.0, 0.5, 0.2]])
    w = np.array([1.0, 3.0])
    p0 = p.copy()
    pbd.solve_internal(p, w, np.array([[0, 1]]), np.array([0.4]), np.zeros((0, 4), np.int64), np.zeros(0),
                       k_stretch=1.0, iterations=1)
    assert abs(np.linalg.norm(p[0] - p[1]) - 0.4) <= 1e-12
    assert np.allclose(((p - p0) / w[:, None]).sum(axis=0), 0.0, atol=1e-12)   # sum m_i dp_i = 0
    p = p0.copy()
    pbd.solve_internal(p, np.array([0.0, 1.0]), np.array([[0, 1]]), np.array([0.4]),
                       np.zeros((0, 4), np.int64), np.zeros(0), k_stretch=1.0, iterations=1)
    assert np.array_equal(p[0], p0[0])


def test_v10_signed_bending_gradient_vs_finite_differences():
    rng = np.random.default_rng(0)
    for _ in range(50):
        P = rng.normal(size=(4, 3))
        q = np.array([[0, 1, 2, 3]])
        g = np.array(pbd.dihedral_gradient(*P))
        num = np.zeros_like(P)
        for i in range(4):
            for k in range(3):
                d = np.zeros_like(P)
                d[i, k] = 1e-6
                num[i, k] = (pbd.signed_dihedrals(P + d, q)[0] - pbd.signed_dihedrals(P - d, q)[0]) / 2e-6
        assert np.max(np.abs(num - g)) <= 1e-5 * max(1.0, np.abs(g).max())
        assert np.allclose(g.sum(axis=0), 0, atol=1e-12)
        assert np.allclose(np.cross(P, g).sum(axis=0), 0, atol=1e-12)


def _quad(deg):
    a = np.deg2rad(deg)
    return (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -np.cos(a), np.sin(a)]], float),
            np.array([[0, 1, 2], [0, 3, 1]]))


def test_v11_flat_zero_and_reflection_flips_sign():
    x, f = _quad(0.0)
    q = pbd.bend_quads(f)
    assert pbd.signed_dihedrals(x, q)[0] == pytest.approx(0.0, abs=1e-15)
    x, _ = _quad(31.0)
    y = x.copy()
    y[3, 2] *= -1
    assert pbd.signed_dihedrals(y, q)[0] == pytest.approx(-pbd.signed_dihedrals(x, q)[0], abs=1e-14)


@pytest.mark.parametrize("rest", [-60.0, 60.0, 170.0, -170.0])
def test_v12_mirror_test_signed_converges_through_flat(rest):
    x, f = _quad(31.0)
    q = pbd.bend_quads(f)
    e = pbd.mesh_edges(f)
    start = np.rad2deg(pbd.signed_dihedrals(x, q)[0])
    target = np.sign(start) * rest            # rest of opposite sign to start for the mirror case
    p = x.copy()
    pbd.solve_internal(p, np.array([0, 0, 0, 1.0]), e, pbd.edge_lengths(x, e), q, np.deg2rad([target]),
                       k_stretch=1.0, k_bend=1.0, iterations=300)
    assert np.rad2deg(pbd.signed_dihedrals(p, q)[0]) == pytest.approx(target, abs=1e-6)


def test_pbd_numba_equals_numpy_twin():
    x, w, e, rl, q, rp = _bent_strip(1, 4, 5)
    a, b = x.copy(), x.copy()
    pbd.solve_internal(a, w, e, rl, q, rp, iterations=5, backend="numba")
    pbd.solve_internal(b, w, e, rl, q, rp, iterations=5, backend="numpy")
    assert np.allclose(a, b, atol=1e-12)


def test_v16_cubic_coefficients_vs_direct():
    rng = np.random.default_rng(2)
    for _ in range(100):
        x, u, y, v, z, w = rng.normal(size=(6, 3))
        A, B, C, D = ccd.cubic_coefficients(x, u, y, v, z, w)
        for t in (0.0, 0.3, 1.0, 1.7):
            direct = np.cross(y + t * v, z + t * w).dot(x + t * u)
            assert A * t ** 3 + B * t ** 2 + C * t + D == pytest.approx(direct, abs=1e-12)


def test_v17_culling_never_culls_a_root():
    rng = np.random.default_rng(3)
    for _ in range(20000):
        c = rng.normal(size=4) * rng.choice([0.1, 1, 10])
        r = np.roots(c)
        has = np.any((np.abs(r.imag) < 1e-12) & (r.real >= 0) & (r.real <= 1))
        if has:
            assert not K._culled(*c)


@pytest.mark.parametrize("roots", [[0.37], [0.2, 0.7], [0.3, 0.3, 0.8], [0.0, 0.5, 1.0], [0.25, 0.5, 0.9]])
def test_v18_root_finder_known_roots(roots):
    got = ccd.cubic_roots01(*np.poly(roots + ([] if len(roots) == 3 else [5.0] * (3 - len(roots)))))
    assert np.allclose(got, sorted(set(roots)), atol=1e-7 if len(set(roots)) < len(roots) else 1e-10)


def test_v19_vt_crossing_beside_and_parity():
    f, x0, x1 = _point_through_triangle()
    tri = x0[1:]
    cons, sides, kind = ccd.detect_collisions(x0, x1, f)
    assert cons.tolist() == [[0, 1, 2, 3]] and sides[0] == 1.0 and kind[0] == 0
    x1b = np.vstack([[1.2, 1.2, -0.63], tri])
    assert len(ccd.detect_collisions(x0, x1b, f)[0]) == 0
    # crossing and re-crossing: triangle vertex a moves so the plane sweeps the point twice
    x0c = np.vstack([[0.2, 0.2, 0.1], tri])
    x1c = np.vstack([[0.2, 0.2, 0.1], [[0, 0, 0.1], [1, 0, 0.1], [0, 1, 0.1]]])
    x1c[1:, 2] = [0.0, 0.0, 0.0]
    assert len(ccd.detect_collisions(x0c, x1c, f)[0]) == 0


def test_v20_ee_crossing_and_skew_rejection():
    # edge (0,1) along x at z=+0.1 moving to z=-0.1; edge (2,3) along y at z=0
    x0 = np.array([[-1, 0, 0.1], [1, 0, 0.1], [0, -1, 0], [0, 1, 0.0]])
    x1 = x0.copy()
    x1[:2, 2] = -0.1
    cons, _ = ccd._narrow(x0, x1, np.array([[0, 1]]), np.array([[0, 1], [2, 3]]),
                          np.array([[0, 1], [2, 3]]), 1, 1e-6, 1e-9)[:2]
    assert len(cons) == 1
    x0s, x1s = x0.copy(), x1.copy()
    x0s[2:, 0] += 3.0                               # coplanar at t=0.5 but far apart
    x1s[2:, 0] += 3.0
    cons, _ = ccd._narrow(x0s, x1s, np.array([[0, 1]]), np.array([[0, 1], [2, 3]]),
                          np.array([[0, 1], [2, 3]]), 1, 1e-6, 1e-9)[:2]
    assert len(cons) == 0


def test_v21_broad_phase_complete_vs_brute_force():
    x0, f, x1 = _two_strips(np.random.default_rng(4), 6, [0.05, 0.05, 0.04])
    verts = np.arange(len(x0))[:, None]
    brute = np.array([(v, t) for v in range(len(x0)) for t in range(len(f)) if v not in f[t]])
    allc, _, _ = ccd._narrow(x0, x1, brute, verts, f, 0, 1e-6, 1e-9)
    for cell in (0.02, 0.1, 0.5):
        cand = ccd.broad_phase(x0, x1, verts, f, pad=0.005, cell=cell)
        s = {tuple(r) for r in cand}
        got = {(c[0], tuple(c[1:])) for c in allc}
        keyed = {(v, tuple(f[t])) for v, t in s}
        assert got <= keyed


def test_v22_collision_projection_restores_side():
    f, x0, x1 = _point_through_triangle()
    cons, sides, _ = ccd.detect_collisions(x0, x1, f)
    p = x1.copy()
    ccd.solve_collisions(p, np.ones(4), cons, sides, h=0.005, k_collision=1.0, iterations=10)
    n = np.cross(p[2] - p[1], p[3] - p[1])
    assert (p[0] - p[1]).dot(n / np.linalg.norm(n)) - 0.005 >= -1e-9


def test_narrow_numba_equals_numpy_twin():
    x0, f, x1 = _two_strips(np.random.default_rng(5), 6, [0.05, 0.05, 0.03])
    a = ccd.detect_collisions(x0, x1, f)
    b = ccd.detect_collisions_numpy(x0, x1, f)
    assert len(a[0]) > 0
    ka = sorted(map(tuple, np.column_stack([a[0], a[1]]).tolist()))
    kb = sorted(map(tuple, np.column_stack([b[0], b[1]]).tolist()))
    assert ka == kb


def test_v23_two_petals_bending_onto_each_other_no_intersections():
    from plantvr.flowers.composer import Canopy, FloretType, SolverParams, grow
    xa, f = _strip(5, 8)
    frames = []
    for k in range(12):                           # petal bends downward along its length
        kappa = 2.5 * k / 11                        # curvature grows: the petal curls down
        y = xa[:, 1]
        fr = xa.copy()
        if kappa > 0:
            fr[:, 1] = np.sin(kappa * y) / kappa
            fr[:, 2] = (np.cos(kappa * y) - 1) / kappa
        frames.append(fr)
    fixed = np.flatnonzero(xa[:, 1] == 0)
    T = FloretType(f, np.array(frames), fixed)
    can = Canopy([T, T], [0, 0], [[0, 0, 0], [0, 0.1, -0.1]], [[0, 0, 1]] * 2, [[1, 0, 0]] * 2, [1.0, 1.0])
    S = np.column_stack([np.linspace(0, 1, 12), np.zeros(12)])
    params = SolverParams(solver_iterations=20)
    _, log = grow(can, S, params, sanity_every=1, prediction="rest")      # the App. B.5 set-up
    assert all(st["intersections"] == 0 for st in log)
    assert sum(st["constraints"] for st in log) > 0
    assert max(st["passes"] for st in log) <= params.max_collision_retries      # V24: bounded retries
    _, log = grow(can, S, params, sanity_every=1)                          # kinematic prediction
    assert all(st["intersections"] == 0 for st in log)
    from plantvr.flowers.ccd import count_static_intersections
    xn, _ = grow(can, S, params, collisions=False, prediction="rest")
    assert count_static_intersections(xn, can.faces) > 0


def test_bad_input_negative_thickness():
    with pytest.raises(ValueError, match="h must be"):
        ccd.detect_collisions(np.zeros((3, 3)), np.zeros((3, 3)), np.array([[0, 1, 2]]), h=-0.1)
    from plantvr.flowers.composer import SolverParams
    with pytest.raises(ValueError, match="spacing"):
        SolverParams(spacing=-0.01)


def test_incremental_redetect_equals_full_detection():
    rng = np.random.default_rng(11)
    x0, f, x1 = _two_strips(rng, 7, [0.03, 0.04, 0.03])
    det = ccd.CollisionDetector(f, len(x0), h=0.005)
    cons, sides, _ = det.detect(x0, x1)
    assert len(cons) > 0
    p = x1.copy()
    for _ in range(4):                              # retries: project, then re-detect incrementally
        ccd.solve_collisions(p, np.ones(len(p)), cons, sides, h=0.005, iterations=3)
        p[rng.integers(0, len(p), 3)] += rng.normal(0, 0.02, (3, 3))   # and some unrelated moves
        cons, sides, kind = det.redetect(p)
        full = ccd.detect_collisions(x0, p, f, h=0.005)
        got = sorted(map(tuple, np.column_stack([cons, sides, kind]).tolist()))
        ref = sorted(map(tuple, np.column_stack(full).tolist()))
        assert got == ref


def test_spatial_hash_broad_phase_equals_brute_force_box_overlap():
    rng = np.random.default_rng(12)
    x0, f = _strip(6, 6)
    x1 = x0 + rng.normal(0, 0.05, x0.shape)
    e = ccd.mesh_edges_of(f)
    lo = np.minimum(np.minimum(x0[e[:, 0]], x0[e[:, 1]]), np.minimum(x1[e[:, 0]], x1[e[:, 1]])) - 0.005
    hi = np.maximum(np.maximum(x0[e[:, 0]], x0[e[:, 1]]), np.maximum(x1[e[:, 0]], x1[e[:, 1]])) + 0.005
    ov = np.all((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None]), axis=2)
    share = (e[:, None, :, None] == e[None, :, None, :]).any(axis=(2, 3))
    brute = {(i, j) for i, j in zip(*np.nonzero(ov & ~share)) if i < j}
    for cell in (0.01, 0.07, 1.0):
        got = {tuple(r) for r in ccd.broad_phase(x0, x1, e, e, pad=0.005, cell=cell, same_set=True)}
        assert got == brute


def test_collision_projection_numba_equals_numpy_twin():
    x0, f, x1 = _two_strips(np.random.default_rng(13), 6, [0.03, 0.04, 0.03])
    cons, sides, _ = ccd.detect_collisions(x0, x1, f)
    assert len(cons) > 5
    w = np.ones(len(x0))
    w[:6] = 0.0
    a, b = x1.copy(), x1.copy()
    K._project_collision(a, w, cons, sides, 0.005, 1.0, 4)
    ccd._project_collision_numpy(b, w, cons, sides, 0.005, 1.0, 4)
    assert np.allclose(a, b, rtol=0, atol=1e-12)


def _b5_scenario(steps=40):
    """App. B.5: two 5x8 petal strips, B 0.08 above A and 0.1 along; A's rest lengths grow by 30 %, B curls
    down onto A by 25 degrees per cross-row hinge; base rows attached."""
    from plantvr.flowers.composer import Canopy, FloretType
    x, f = _strip(5, 8)
    row = np.rint(x[:, 1] / 0.1).astype(int)
    grow_a = np.array([x * (1 + 0.3 * k / steps) for k in range(steps + 1)])
    curl_b = []
    for k in range(steps + 1):
        seg = -np.deg2rad(25.0) * k / steps * np.arange(7)          # direction of segment j (downward curl)
        fr = x.copy()
        fr[:, 1] = np.concatenate([[0], np.cumsum(0.1 * np.cos(seg))])[row]
        fr[:, 2] = np.concatenate([[0], np.cumsum(0.1 * np.sin(seg))])[row]
        curl_b.append(fr)
    fixed = np.flatnonzero(row == 0)
    ta, tb = FloretType(f, grow_a, fixed), FloretType(f, np.array(curl_b), fixed)
    can = Canopy([ta, tb], [0, 1], [[0, 0, 0], [0, 0.1, 0.08]], [[0, 0, 1]] * 2, [[1, 0, 0]] * 2, [1.0, 1.0])
    return can, np.column_stack([np.linspace(0, 1, steps + 1)] * 2), ta, tb


def test_v24_collision_retries_bounded_in_b5_scenario():
    from plantvr.flowers.composer import SolverParams, grow
    can, S, ta, tb = _b5_scenario()
    assert np.allclose(ta.rest_len[-1] / ta.rest_len[0], 1.3)
    hinge = np.abs(np.rad2deg(tb.rest_phi[-1] - tb.rest_phi[0]))
    assert np.allclose(hinge.max(), 25.0) and np.allclose(np.sort(np.unique(hinge.round(9))), [0.0, 25.0])
    params = SolverParams(solver_iterations=20)                     # App. B.5: 20 internal iterations
    x, log = grow(can, S, params, sanity_every=1, prediction="rest")
    passes = [st["passes"] for st in log]
    assert max(passes) <= 3 < params.max_collision_retries          # V24 (PROTOTYPE: max 3)
    assert all(st["rolled_back"] == 0 for st in log)                 # never needed the fallback
    assert sum(st["constraints"] for st in log) > 0
    assert all(st["intersections"] == 0 for st in log)               # V23 on the same scenario
    assert x[:40][np.rint(_strip()[0][:, 1] / 0.1) == 7][:, 2].max() < -0.01   # A pushed down by contact
    _, log_off = grow(can, S, params, collisions=False, sanity_every=1, prediction="rest")
    assert max(st["intersections"] for st in log_off) > 0            # control: petals pass through


def _cloth(n=10, h=0.1):
    x, f = _strip(n, n, size=h)
    e, q = pbd.mesh_edges(f), pbd.bend_quads(f)
    w = np.ones(len(x))
    w[x[:, 1] == 0] = 0.0                                            # pinned row
    p0 = x + np.random.default_rng(0).normal(0, 0.2 * h, x.shape)
    p0[w == 0] = x[w == 0]
    return p0, w, e, pbd.edge_lengths(x, e), q, np.zeros(len(q))


def _iterations_to_converge(method, omega=1.0, chunk=25, limit=40000):
    p, w, e, rl, q, rp = _cloth()
    for it in range(chunk, limit + 1, chunk):
        pbd.solve_internal(p, w, e, rl, q, rp, k_stretch=1.0, k_bend=1.0, iterations=chunk, method=method,
                           omega=omega)
        if np.abs(pbd.edge_lengths(p, e) - rl).max() <= 1e-4 * 0.1:
            return it, p
    return None, p


def test_v26_jacobi_and_gauss_seidel_both_converge_on_pinned_cloth():
    gs, p_gs = _iterations_to_converge("gauss-seidel")
    jac, p_j = _iterations_to_converge("jacobi", omega=1.5)
    assert gs is not None and jac is not None                        # residual <= 1e-4 x edge length
    assert gs < jac                                                   # Gauss-Seidel needs fewer iterations
    w = _cloth()[1]
    assert np.array_equal(p_gs[w == 0], p_j[w == 0])                # pins hold under both


def test_v26_jacobi_does_not_depend_on_constraint_order():
    p, w, e, rl, q, rp = _cloth()
    rng = np.random.default_rng(7)
    pe, pq = rng.permutation(len(e)), rng.permutation(len(q))
    results = {}
    for method in ("jacobi", "gauss-seidel"):
        a, b = p.copy(), p.copy()
        pbd.solve_internal(a, w, e, rl, q, rp, iterations=20, method=method)
        pbd.solve_internal(b, w, e[pe], rl[pe], q[pq], rp[pq], iterations=20, method=method)
        results[method] = np.abs(a - b).max()
    assert results["jacobi"] <= 1e-12
    assert results["gauss-seidel"] > 1e-6                             # Gauss-Seidel does


def test_jacobi_numba_equals_numpy_twin():
    x, w, e, rl, q, rp = _bent_strip(8, 4, 5)
    a, b = x.copy(), x.copy()
    pbd.solve_internal(a, w, e, rl, q, rp, iterations=7, method="jacobi", omega=1.3, backend="numba")
    pbd.solve_internal(b, w, e, rl, q, rp, iterations=7, method="jacobi", omega=1.3, backend="numpy")
    assert np.abs(a - b).max() <= 1e-12 and np.abs(a - x).max() > 1e-3
    assert np.array_equal(a[:4], x[:4])


def test_jacobi_bad_input_leaves_positions_untouched():
    p, w, e, rl, q, rp = _cloth(4)
    before = p.copy()
    with pytest.raises(ValueError, match="method must be one of"):
        pbd.solve_internal(p, w, e, rl, q, rp, method="sor")
    with pytest.raises(ValueError, match="omega must be in"):
        pbd.solve_internal(p, w, e, rl, q, rp, method="jacobi", omega=2.0)
    assert np.array_equal(p, before)


@pytest.fixture
def pbd_nojit(monkeypatch):
    import importlib

    import numba
    monkeypatch.setattr(numba.core.config, "DISABLE_JIT", True)
    yield importlib.reload(pbd)
    monkeypatch.undo()
    importlib.reload(pbd)


def test_pbd_kernels_without_jit_match_twins(pbd_nojit):
    """The kernels run as plain Python (coverage sees their lines) and equal the numpy twins (STYLE §8)."""
    mod = pbd_nojit
    x, w, e, rl, q, rp = _bent_strip(9, 3, 4, noise=0.03, pinned=3, mod=mod)
    for method in ("gauss-seidel", "jacobi"):
        a, b = x.copy(), x.copy()
        mod.solve_internal(a, w, e, rl, q, rp, iterations=3, method=method, omega=1.2, backend="numba")
        mod.solve_internal(b, w, e, rl, q, rp, iterations=3, method=method, omega=1.2, backend="numpy")
        assert np.abs(a - b).max() <= 1e-12 and np.abs(a - x).max() > 1e-4
