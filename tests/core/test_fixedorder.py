"""Linear algebra in a fixed order against numpy.linalg and scipy.linalg (a second
implementation each), and the same bits in a process forced to each OpenBLAS kernel."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from conftest import BLAS_KERNELS, run_with_blas_kernel

from probing.core import fixedorder as fo


def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    a = rng.standard_normal((n, n))
    return a @ a.T + n * np.eye(n)


@pytest.mark.parametrize(
    ("a_shape", "b_shape"),
    [((7,), (7,)), ((5, 7), (7,)), ((7,), (7, 3)), ((5, 7), (7, 3)), ((2, 4, 7), (7,))],
)
def test_dot_is_numpys_product(a_shape, b_shape) -> None:
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal(a_shape), rng.standard_normal(b_shape)
    got = fo.dot(a, b)
    assert got.shape == (a @ b).shape
    np.testing.assert_allclose(got, a @ b, rtol=1e-13, atol=1e-13)


def test_dot_in_blocks_of_rows_is_the_same_bits(monkeypatch) -> None:
    """A product too large for one temporary is done in blocks of rows: the same floats."""
    rng = np.random.default_rng(1)
    a, b = rng.standard_normal((37, 11)), rng.standard_normal((11, 5))
    whole = fo.dot(a, b)
    monkeypatch.setattr(fo, "_BLOCK", 60)  # one row of 55 products at a time
    assert np.array_equal(fo.dot(a, b), whole)


def test_dot_refuses_shapes_that_do_not_multiply() -> None:
    with pytest.raises(ValueError, match="cannot multiply"):
        fo.dot(np.ones((2, 3)), np.ones((4, 2)))
    with pytest.raises(ValueError, match="cannot multiply"):
        fo.dot(np.ones((2, 2, 3)), np.ones((3, 2)))


def test_vdot_norm_and_cov_are_numpys() -> None:
    rng = np.random.default_rng(2)
    x, y = rng.standard_normal(101), rng.standard_normal(101)
    assert fo.vdot(x, y) == pytest.approx(float(np.dot(x, y)), rel=1e-13)
    assert fo.norm(x) == pytest.approx(float(np.linalg.norm(x)), rel=1e-14)
    obs = rng.standard_normal((40, 6))
    np.testing.assert_allclose(fo.cov(obs), np.cov(obs, rowvar=False), rtol=1e-12)
    with pytest.raises(ValueError, match="one length"):
        fo.vdot(x, y[:-1])
    with pytest.raises(ValueError, match="two or more rows"):
        fo.cov(obs[:1])


@pytest.mark.parametrize("n", [1, 2, 6, 13])
def test_solve_and_inv_are_numpys(n) -> None:
    rng = np.random.default_rng(n)
    a = rng.standard_normal((n, n)) + 3 * np.eye(n)
    b, bb = rng.standard_normal(n), rng.standard_normal((n, 4))
    np.testing.assert_allclose(fo.solve(a, b), np.linalg.solve(a, b), rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(fo.solve(a, bb), np.linalg.solve(a, bb), rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(fo.inv(a), np.linalg.inv(a), rtol=1e-12, atol=1e-13)


def test_solve_pivots_on_a_zero_diagonal_and_refuses_a_singular_matrix() -> None:
    a = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0]])
    assert fo.solve(a, np.array([2.0, 5.0, 4.0])).tolist() == [5.0, 2.0, 2.0]
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        fo.solve(np.array([[1.0, 2.0], [2.0, 4.0]]), np.ones(2))


def test_cholesky_and_the_stacked_triangular_solve_are_numpys() -> None:
    rng = np.random.default_rng(3)
    s = _spd(rng, 6)
    low = fo.cholesky(s)
    np.testing.assert_allclose(low, np.linalg.cholesky(s), rtol=1e-12, atol=1e-13)
    lows = np.tril(rng.standard_normal((9, 6, 6))) + 4 * np.eye(6)
    rhs = rng.standard_normal((9, 6, 3))
    np.testing.assert_allclose(
        fo.solve_lower(lows, rhs), np.linalg.solve(lows, rhs), rtol=1e-12, atol=1e-13
    )
    np.testing.assert_allclose(
        fo.solve_lower(lows[0], rhs[0, :, 0]), np.linalg.solve(lows[0], rhs[0, :, 0]), rtol=1e-12
    )
    with pytest.raises(np.linalg.LinAlgError, match="positive definite"):
        fo.cholesky(np.array([[1.0, 2.0], [2.0, 1.0]]))


def test_lstsq_and_pinv_are_numpys_for_full_column_rank() -> None:
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 1.0, 50)
    a = np.column_stack([t**k for k in range(1, 5)])  # the trend's powers: far from orthogonal
    b = rng.standard_normal((50, 2))
    np.testing.assert_allclose(fo.lstsq(a, b), np.linalg.lstsq(a, b, rcond=None)[0], rtol=1e-9)
    np.testing.assert_allclose(fo.pinv(a), np.linalg.pinv(a), rtol=1e-9, atol=1e-9)
    with pytest.raises(np.linalg.LinAlgError, match="combination"):
        fo.lstsq(np.column_stack((t, 2 * t)), b)
    with pytest.raises(ValueError, match="at least as many rows"):
        fo.pinv(a.T)


@pytest.mark.parametrize("scale", [1e-3, 0.1, 1.0, 20.0])
def test_expm_is_scipys(scale) -> None:
    rng = np.random.default_rng(5)
    a = scale * rng.standard_normal((8, 8))
    want = scipy.linalg.expm(a)
    np.testing.assert_allclose(fo.expm(a), want, rtol=1e-12, atol=1e-14 * np.abs(want).max())


def test_matrix_power_is_numpys() -> None:
    a = np.random.default_rng(6).standard_normal((5, 5)) / 3
    for n in (0, 1, 2, 7, 64, 255):
        want = np.linalg.matrix_power(a, n)
        np.testing.assert_allclose(fo.matrix_power(a, n), want, rtol=1e-11, atol=1e-15)
    with pytest.raises(ValueError, match=">= 0"):
        fo.matrix_power(a, -1)


@pytest.mark.parametrize("n", range(1, 11))
def test_eigvals_are_numpys(n) -> None:
    """Random matrices of rows scaled over four decades (as an aircraft's states in ft/s and
    rad): the same eigenvalues as LAPACK's to 1e-12 of the largest, complex pairs with the
    positive imaginary part first."""
    rng = np.random.default_rng(n)
    for _ in range(40):
        a = rng.standard_normal((n, n)) * np.exp(2.0 * rng.standard_normal((n, 1)))
        got, want = fo.eigvals(a), np.linalg.eigvals(a)
        scale = max(1.0, float(np.abs(want).max()))
        np.testing.assert_allclose(np.sort_complex(got), np.sort_complex(want), atol=1e-12 * scale)
        pairs = np.flatnonzero(got.imag > 0)
        assert np.all(got[pairs + 1] == np.conj(got[pairs]))


def test_eigvals_of_a_gtm_like_longitudinal_matrix() -> None:
    """A short period -2 +- 3i and a lightly damped phugoid -0.01 +- 0.2i, in a basis that
    mixes them (what a longitudinal state matrix is): both pairs to 1e-12."""
    rng = np.random.default_rng(8)
    blocks = np.zeros((4, 4))
    blocks[:2, :2] = [[-2.0, 3.0], [-3.0, -2.0]]
    blocks[2:, 2:] = [[-0.01, 0.2], [-0.2, -0.01]]
    basis = rng.standard_normal((4, 4)) * np.array([100.0, 1.0, 1.0, 0.1])[:, None]
    a = basis @ blocks @ np.linalg.inv(basis)
    got = fo.eigvals(a)
    want = np.array([-2 + 3j, -2 - 3j, -0.01 + 0.2j, -0.01 - 0.2j])
    np.testing.assert_allclose(np.sort_complex(got), np.sort_complex(want), atol=1e-12)


#: Every function on fixed random inputs, each result's bytes hashed.
BATTERY = """
import hashlib, numpy as np
from probing.core import fixedorder as fo
rng = np.random.default_rng(7)
a, b = rng.standard_normal((40, 300)), rng.standard_normal((300, 9))
s = fo.dot(a[:, :9].T, a[:, :9]) + np.eye(9)
out = [fo.dot(a, b), fo.dot(a, b[:, 0]), fo.vdot(a[0], a[1]), fo.cov(a[:, :9]), fo.inv(s),
       fo.solve(s, b[:9]), fo.cholesky(s), fo.lstsq(a[:, :4], a[:, 4:6]),
       fo.expm(s / 10), fo.matrix_power(s / 20, 37), fo.norm(a[3]), fo.eigvals(s - 2 * s.T)]
print(hashlib.sha256(b"".join(np.asarray(x).tobytes() for x in out)).hexdigest())
"""


@pytest.mark.parametrize("kernel", sorted(BLAS_KERNELS))
def test_the_same_bits_under_every_blas_kernel(kernel) -> None:
    """Each function gives the same bytes in a process forced to each OpenBLAS kernel as
    here (numpy's own product, ``a @ b`` of these shapes, differs between Haswell and
    SkylakeX)."""
    here = {}
    exec(BATTERY, {"print": lambda digest: here.setdefault("digest", digest)})
    assert run_with_blas_kernel(kernel, ["-c", BATTERY]).strip() == here["digest"]


def test_a_kernel_without_avx512_runs_numpy_without_it() -> None:
    """The kernel runs of a processor without AVX-512 keep numpy off its AVX-512 paths too."""
    if "avx512f" not in open("/proc/cpuinfo").read():
        pytest.skip("this CPU has no AVX-512: numpy has none to leave")
    snippet = "from numpy._core._multiarray_umath import __cpu_features__ as f; print(f['X86_V4'])"
    assert run_with_blas_kernel("Haswell", ["-c", snippet]).strip() == "False"
    assert run_with_blas_kernel("SkylakeX", ["-c", snippet]).strip() == "True"
