"""Point-mass modes of a batch (rank_one_modes): the vectorised secular-equation solve against the
dense generalised eigen-solve and against the per-row LAPACK dstemr path, on random cases."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from beam.physics import modal


def _case(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, n))
    b = rng.normal(size=(n, n))
    return b @ b.T / n + 0.1 * np.eye(n), a @ a.T + n * np.eye(n), rng.normal(size=n)


@pytest.mark.parametrize("seed", range(12))
def test_secular_batch_matches_dense_and_dstemr(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    n, count = 5 + 4 * seed, 1 + seed % 5
    mass, stiffness, vector = _case(n, seed)
    factors = modal.rank_one_factorisation(mass, stiffness, vector)
    alpha = 10 ** np.random.default_rng(100 + seed).uniform(-8, 3, 40)
    omega2, shapes = modal.rank_one_modes(factors, alpha, count)  # the secular path
    monkeypatch.setattr(modal, "SECULAR_ITERATIONS", 0)  # every row unsettled: the dstemr path
    omega2_ref, shapes_ref = modal.rank_one_modes(factors, alpha, count)
    signs = np.sign(np.sum(shapes * shapes_ref, axis=1, keepdims=True))
    np.testing.assert_allclose(omega2, omega2_ref, rtol=1e-11)
    assert np.max(np.abs(shapes * signs - shapes_ref)) <= 1e-8 * np.max(np.abs(shapes_ref))
    for b in range(0, alpha.size, 9):
        values, vectors = scipy.linalg.eigh(stiffness, mass + alpha[b] * np.outer(vector, vector))
        np.testing.assert_allclose(omega2[b], values[:count], rtol=1e-11)
        dense = vectors[:, :count]
        one = shapes[b] * np.sign(np.sum(shapes[b] * dense, axis=0))
        assert np.max(np.abs(one - dense)) <= 1e-9 * np.max(np.abs(dense))


def test_zero_and_tiny_point_mass_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    """alpha = 0 (dstemr) and alpha -> 0 (roots at the poles) in one batch agree with the dense solve."""
    mass, stiffness, vector = _case(30, 7)
    factors = modal.rank_one_factorisation(mass, stiffness, vector)
    alpha = np.concatenate([[0.0, 1e-14, 1e-10], np.linspace(1e-3, 2.0, 30)])
    omega2, shapes = modal.rank_one_modes(factors, alpha, 4)
    for b in range(alpha.size):
        values, vectors = scipy.linalg.eigh(stiffness, mass + alpha[b] * np.outer(vector, vector))
        np.testing.assert_allclose(omega2[b], values[:4], rtol=1e-11)
        one = shapes[b] * np.sign(np.sum(shapes[b] * vectors[:, :4], axis=0))
        assert np.max(np.abs(one - vectors[:, :4])) <= 1e-8 * np.max(np.abs(vectors[:, :4]))
