"""The compiled positive semidefinite projection (torsal.geometry.optimize.psd_kernel) against
numpy's eigh, one element at a time, and against matrices built from known eigenpairs."""
import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from torsal.geometry.congruence import Congruence
from torsal.geometry.optimize import CongruenceProblem, projected, psd_kernel
from torsal.geometry.surfaces import canopy, facade_patch

pytestmark = pytest.mark.skipif(not psd_kernel.available(), reason="no C compiler: numpy's eigh is used")


def _by_numpy(a: np.ndarray, mode: str) -> np.ndarray:
    """Each matrix on its own: V f(L) V^T by numpy's eigh where an eigenvalue is negative."""
    out = a.copy()
    with threadpool_limits(1):      # a 32 x 32 eigh in threaded BLAS: seconds on a loaded machine
        for e, m in enumerate(a):
            w, v = np.linalg.eigh(m)
            if w[0] < 0:
                f = np.abs(w) if mode == "abs" else np.maximum(w, 0.0)
                out[e] = (v * f) @ v.T
    return out


def _random_symmetric(rng, m: int, n: int) -> np.ndarray:
    """Symmetric matrices with entries of sizes 1e-8 to 1e8 (one size per matrix)."""
    a = rng.standard_normal((m, n, n)) * 10.0 ** rng.uniform(-8, 8, (m, 1, 1))
    return a + a.transpose(0, 2, 1)


@pytest.mark.parametrize("n", [1, 3, 6, 8, 9, 12, psd_kernel.NMAX])
@pytest.mark.parametrize("mode", ["clamp", "abs"])
def test_kernel_equals_numpy_eigh_per_element(n, mode):
    """Random symmetric blocks: the kernel's projection is numpy's (one eigh per element) to
    1e-12 of each matrix's largest entry; matrices without a negative eigenvalue unchanged."""
    rng = np.random.default_rng(n)
    a = _random_symmetric(rng, 500, n)
    spd = rng.standard_normal((50, n, n))
    spd = spd @ spd.transpose(0, 2, 1) + n * np.eye(n)        # positive definite
    a = np.concatenate([a, spd])
    out = a.copy()
    assert psd_kernel.project(out, mode).size == 0
    scale = np.abs(a).max(axis=(1, 2))[:, None, None]
    np.testing.assert_allclose(out / scale, _by_numpy(a, mode) / scale, rtol=0, atol=1e-12)
    assert np.array_equal(out[-50:], a[-50:])
    assert np.array_equal(out, out.transpose(0, 2, 1))        # exactly symmetric


def test_kernel_on_known_eigenpairs():
    """Q diag(l) Q^T with repeated, zero and negative eigenvalues (clusters that make the
    eigenvectors ill-determined, not the projection) -> Q diag(max(l, 0)) Q^T, and the
    nearest positive semidefinite matrix: no other one closer."""
    rng = np.random.default_rng(7)
    n = 8
    spectra = np.array([[3.0, 3.0, 3.0, -1.0, -1.0, 0.0, 0.0, 2.0],
                        [-2.0] * 8,
                        [1e-9, -1e-9, 5.0, -5.0, 1.0 + 1e-12, 1.0, -3.0, -3.0 + 1e-13],
                        [0.0] * 7 + [-1.0]])
    q = np.linalg.qr(rng.standard_normal((len(spectra), n, n)))[0]
    a = (q * spectra[:, None, :]) @ q.transpose(0, 2, 1)
    a = 0.5 * (a + a.transpose(0, 2, 1))
    out = a.copy()
    assert psd_kernel.project(out, "clamp").size == 0
    expect = (q * np.maximum(spectra, 0.0)[:, None, :]) @ q.transpose(0, 2, 1)
    np.testing.assert_allclose(out, expect, rtol=0, atol=1e-12)
    b = rng.standard_normal((n, n))
    assert np.linalg.norm(a[0] - out[0]) <= np.linalg.norm(a[0] - b @ b.T)
    # diagonal and zero matrices: the projection is exact
    d = np.zeros((2, n, n))
    d[0][np.diag_indices(n)] = np.arange(n) - 3.0
    out = d.copy()
    psd_kernel.project(out, "abs")
    assert np.array_equal(out[0], np.diag(np.abs(np.arange(n) - 3.0))) and not out[1].any()


def test_matrices_not_finite_are_left_to_numpy(monkeypatch):
    """A matrix with a NaN is left as it is and named; psd_projection hands it to numpy's eigh,
    so the batch ends as it did without the kernel (numpy's LinAlgError, or its NaNs)."""
    monkeypatch.setattr(projected, "PSD_KERNEL", "compiled")
    rng = np.random.default_rng(1)
    a = _random_symmetric(rng, 6, 8)
    a[2, 1, 4] = a[2, 4, 1] = np.nan
    out = a.copy()
    np.testing.assert_array_equal(psd_kernel.project(out, "clamp"), [2])
    np.testing.assert_array_equal(out[2], a[2])

    def outcome():
        try:
            return np.isnan(projected.psd_projection(a))
        except np.linalg.LinAlgError:
            return "LinAlgError"
    with_kernel = outcome()
    monkeypatch.setattr(psd_kernel, "_LIB", False)
    without = outcome()
    assert type(with_kernel) is type(without) and np.array_equal(with_kernel, without)


def test_psd_projection_with_and_without_the_kernel(monkeypatch):
    """psd_projection by the kernel (PSD_KERNEL "compiled", the default) and by numpy's eigh
    (PSD_KERNEL "numpy", and the path without a C compiler) agree to 1e-12; the kernel is
    deterministic (the same bytes twice)."""
    rng = np.random.default_rng(5)
    a = _random_symmetric(rng, 3000, 8)
    assert projected.PSD_KERNEL == "compiled"
    with_kernel = projected.psd_projection(a)       # the default
    monkeypatch.setattr(projected, "PSD_KERNEL", "numpy")
    by_numpy = projected.psd_projection(a)
    monkeypatch.setattr(projected, "PSD_KERNEL", "compiled")
    assert np.array_equal(with_kernel, projected.psd_projection(a))
    assert not np.array_equal(with_kernel, by_numpy)    # the kernel was used: other rounding
    monkeypatch.setattr(psd_kernel, "_LIB", False)
    assert psd_kernel.project(a.copy(), "clamp") is None
    without = projected.psd_projection(a)
    assert np.array_equal(without, by_numpy)
    scale = np.abs(a).max(axis=(1, 2))[:, None, None]
    np.testing.assert_allclose(with_kernel / scale, without / scale, rtol=0, atol=1e-12)


def test_project_refuses_what_it_cannot_write():
    with pytest.raises(ValueError, match="mode"):
        psd_kernel.project(np.zeros((1, 3, 3)), "nearest")
    with pytest.raises(ValueError, match="C-contiguous"):
        psd_kernel.project(np.zeros((3, 3, 2)).transpose(0, 2, 1)[:, :2, :2].copy(order="F"), "clamp")
    assert psd_kernel.project(np.zeros((1, psd_kernel.NMAX + 1, psd_kernel.NMAX + 1)), "clamp") is None


_SUN = np.array([0.3, -0.8, -0.5]) / np.linalg.norm([0.3, -0.8, -0.5])
#: test_optimize_alm's agreement cases: each bound active at the optimum
_CASES = {
    "canopy, min_torsal_angle 80": lambda: CongruenceProblem(Congruence.from_normals(canopy(nu=7, nv=7))).normal()
    .fair().perpendicular([0.2, 0.3, -0.9]).closeness(weight=0.1).hyperbolic().min_torsal_angle(80),
    "facade, min_torsal_angle 60": lambda: CongruenceProblem(Congruence.from_normals(facade_patch(nu=8, nv=8)))
    .normal().fair().perpendicular(_SUN, weight=10).closeness(weight=0.3).min_torsal_angle(60),
}


@pytest.mark.parametrize("case", sorted(_CASES))
def test_both_projections_solve_to_the_same_optimum(case, monkeypatch):
    """The augmented Lagrangian with numpy's eigh and with the compiled kernel (the same
    projection to rounding, other rounding) ends at the same design: both measured feasible,
    the objectives within 0.1 %, every line within 0.5 degree. The two paths need not agree
    step for step; the answer does (a solve whose length rested on digits past the 15th
    would end elsewhere, issue 44's row 9)."""
    runs = {}
    for kernel in ("numpy", "compiled"):
        monkeypatch.setattr(projected, "PSD_KERNEL", kernel)
        runs[kernel] = _CASES[case]().solve(solver="alm")
    a, b = runs["numpy"], runs["compiled"]
    assert a.success and b.success, (a.status, b.status)
    assert all(m.holds for m in a.measured.values()) and all(m.holds for m in b.measured.values())
    assert a.objective == pytest.approx(b.objective, rel=1e-3)
    ea, eb = a.congruence.directions, b.congruence.directions
    cos = np.sum(ea * eb, axis=1) / np.linalg.norm(ea, axis=1) / np.linalg.norm(eb, axis=1)
    assert np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).max() < 0.5
