"""The compiled filter's small kernels against independent references.

The smoother's Cholesky solve and the scalar update's P h are written for speed (four rows of the
substitution per pass, P h column by column); each element must still see the same operations in
the same order as the plain row-at-a-time formulas written out here in Python, so the results are
compared bit for bit, and against numpy's dense algebra to rounding. Φ is built in caller work
space: whatever that space held before must not leak into Φ.
"""

import numpy as np
import pytest

from ldvsurvey.nav import kfloop


def _spd(n, seed):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n)) * np.logspace(-4, 1, n)  # badly scaled columns, like a covariance
    return a @ a.T + 1e-9 * np.eye(n), rng.standard_normal((n, n))


def _chol_solve_reference(S, B):
    """X = S⁻¹ B by Cholesky, one row and one operation at a time (plain Python floats)."""
    n, m = B.shape
    L = [[0.0] * n for _ in range(n)]
    for j in range(n):
        d = float(S[j, j])
        for k in range(j):
            d -= L[j][k] * L[j][k]
        d = float(np.sqrt(d))
        L[j][j] = d
        for i in range(j + 1, n):
            s = float(S[i, j])
            for k in range(j):
                s -= L[i][k] * L[j][k]
            L[i][j] = s / d
    X = [[float(B[i, c]) for c in range(m)] for i in range(n)]
    for i in range(n):
        for k in range(i):
            for c in range(m):
                X[i][c] -= L[i][k] * X[k][c]
        for c in range(m):
            X[i][c] /= L[i][i]
    for i in range(n - 1, -1, -1):
        for k in range(i + 1, n):
            for c in range(m):
                X[i][c] -= L[k][i] * X[k][c]
        for c in range(m):
            X[i][c] /= L[i][i]
    return np.array(X)


@pytest.mark.parametrize("n", [3, 4, 7, 16, 21])  # fewer rows than one pass of four, exact passes, remainders
def test_chol_solve_bit_for_bit(n):
    S, B = _spd(n, n)
    X = np.empty((n, n))
    kfloop._chol_solve(S, B, np.empty((n, n)), X)
    np.testing.assert_array_equal(X, _chol_solve_reference(S, B))
    # and a solution: a backward error at rounding level (the columns are scaled over five decades)
    np.testing.assert_allclose(S @ X, B, rtol=0, atol=1e-13 * n * np.abs(S).max() * np.abs(X).max())


def test_chol_solve_falls_back_when_not_positive_definite():
    n = 6
    S, B = _spd(n, 1)
    S[2, 2] = -1.0  # indefinite: the factorization stops, LU takes over
    X = np.empty((n, n))
    kfloop._chol_solve(S, B, np.empty((n, n)), X)
    np.testing.assert_allclose(X, np.linalg.solve(S, B), rtol=1e-12)


def test_cov_row_bit_for_bit_and_dense():
    n = 21
    P, _ = _spd(n, 5)
    P[3, 7] += 1e-6  # not exactly symmetric, as between sequential updates
    H = np.zeros((3, n))
    H[1, [0, 2, 4, 15, 17, 20]] = [0.3, -2.0, 1.0, 0.5, -0.25, 1e-3]
    ph = np.empty(n)
    s = kfloop._cov_row(P, H, 1, 0.04, ph, np.empty(n, dtype=np.int64))
    h = H[1]
    nz = np.flatnonzero(h)
    ref = np.empty(n)
    for i in range(n):  # the non-zeros in column order, summed one after the other from 0
        acc = 0.0
        for c in nz:
            acc += P[i, c] * h[c]
        ref[i] = acc
    s_ref = 0.0
    for c in nz:
        s_ref += h[c] * ref[c]
    np.testing.assert_array_equal(ph, ref)
    assert s == s_ref + 0.04
    np.testing.assert_allclose(ph, P @ h, rtol=1e-12, atol=1e-14 * np.abs(P).max())
    assert s == pytest.approx(h @ P @ h + 0.04, rel=1e-12)


def test_phi_ignores_what_its_work_space_held():
    n = 21
    rng = np.random.default_rng(2)
    fin = np.zeros(kfloop.N_FIN)
    c = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    fin[0:9] = c.ravel()
    fin[9:15] = [0.3, -0.2, 9.81, 12.0, -3.0, 0.1]  # mean f^n (m/s²), v (m/s)
    fin[15:18] = [0.8, 120.0, 0.01]  # lat (rad), h (m), mean ω_z (rad/s)
    inv_tau = np.zeros(n)
    inv_tau[9:15] = 1.0 / 3600.0
    phi_clean, phi_dirty = np.empty((n, n)), np.empty((n, n))
    kfloop._phi_into(fin, 0.1, inv_tau, 20, -1, phi_clean, np.zeros((n, n)), np.zeros(n))
    kfloop._phi_into(fin, 0.1, inv_tau, 20, -1, phi_dirty, np.full((n, n), np.nan), np.full(n, 1e300))
    np.testing.assert_array_equal(phi_dirty, phi_clean)
    # and Φ is I + F T + (F T)²/2 of the F it was built from (dense reference, to rounding)
    A = np.zeros((n, n))
    kfloop._phi_into(fin, 1.0, np.zeros(n), 20, -1, np.empty((n, n)), A, np.zeros(n))  # leaves F·1 (− 0) in A
    F = A.copy()
    F[np.arange(n), np.arange(n)] -= inv_tau
    FT = F * 0.1
    np.testing.assert_allclose(phi_clean, np.eye(n) + FT + FT @ FT / 2, rtol=1e-12, atol=1e-15)


def test_mech_step_into_matches_the_allocating_step():
    """The filter's in-place step on a NavState against :func:`mech_step` (the vector formulas), to
    rounding; on return the state one interval earlier is the one it started from."""
    from ldvsurvey.nav.mech import NavState, mech_step, mech_step_into

    rng = np.random.default_rng(7)
    q = rng.standard_normal(4)
    q /= np.linalg.norm(q)
    v, v_prev = rng.normal(0, 10, 3), rng.normal(0, 10, 3)
    pos = np.array([0.9, 0.2, 150.0])
    pos_prev = pos - np.array([1e-7, -2e-7, 0.05])
    dth_prev, dv_prev = rng.normal(0, 1e-3, 3), rng.normal(0, 0.1, 3)
    dth, dv = rng.normal(0, 1e-3, 3), rng.normal(0, 0.1, 3)
    args = (0.01, 2e-5, -3e-5, 4e-4)  # dt (s), ξ, η (rad), δg (m/s²)
    q_ref, v_ref, p_ref, f_ref = mech_step(NavState(q, v, pos, v_prev, pos_prev, dth_prev, dv_prev), dth, dv, *args)
    nav = NavState(q.copy(), v.copy(), pos.copy(), v_prev.copy(), pos_prev.copy(), dth_prev.copy(), dv_prev.copy())
    f_n = np.empty(3)
    mech_step_into(nav, dth, dv, *args, f_n)
    np.testing.assert_allclose(nav.q_sn, q_ref, rtol=0, atol=1e-15)
    np.testing.assert_allclose(nav.v_n_mps, v_ref, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(nav.pos_rad_m, p_ref, rtol=1e-15, atol=0)
    np.testing.assert_allclose(f_n, f_ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(nav.v_prev_n_mps, v)
    np.testing.assert_array_equal(nav.pos_prev_rad_m, pos)
    assert np.abs(v_ref - v).max() > 1e-3  # the step moved the state: the comparison is not vacuous
