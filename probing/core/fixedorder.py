"""Linear algebra whose every sum is taken in one fixed order: the same bits on any machine.

numpy's ``@``, ``np.dot``, ``np.cov``, ``np.convolve`` and ``np.linalg`` hand their sums to
BLAS and LAPACK (OpenBLAS in numpy's and scipy's wheels), which pick a kernel for the
processor at run time (``OPENBLAS_CORETYPE``: Prescott, Sandybridge, Haswell, Zen, SkylakeX,
...).  The kernels add the terms of a dot product in different orders (4 or 8 at a time,
with or without fused multiply-add), so a result differs in its last bits from one processor
to the next, and a statistic that is a difference of large numbers can move by much more.

Here a product is numpy's element-wise multiplication (exactly rounded, whatever the
instruction set) and a sum is numpy's reduction along the last, contiguous axis (pairwise
summation in blocks of eight, written in C without fused operations: one order on every
x86-64 processor).  The rest (elimination, back substitution, scaling and squaring) is
written out in those two operations.  Meant for the small systems of the monitor and the
linearised aircraft (tens of unknowns): no blocking, O(n^3) in numpy element-wise work.

Hand-written because no maintained package offers reproducible dense linear algebra
for numpy: ReproBLAS is C only, and MKL's conditional numerical reproducibility is not what
numpy's wheels link.  Tested against numpy.linalg and scipy.linalg
(``tests/core/test_fixedorder.py``) and for the same bytes under every OpenBLAS kernel
(``tests/sweep/test_result_bytes.py``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "cholesky",
    "cov",
    "dot",
    "eigvals",
    "expm",
    "inv",
    "lstsq",
    "matrix_power",
    "norm",
    "orthonormal_complement",
    "pinv",
    "solve",
    "solve_lower",
    "vdot",
]

#: Largest temporary of a product, elements: rows are done in blocks below it.
_BLOCK = 1 << 21


def vdot(a: np.ndarray, b: np.ndarray) -> float:
    """<a, b> of two vectors of equal length (their units multiplied).

    Examples
    --------
    >>> vdot(np.array([1.0, 2.0, 3.0]), np.array([4.0, 5.0, 6.0]))
    32.0
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.ndim != 1 or a.shape != b.shape:
        raise ValueError(f"vdot needs two vectors of one length, got {a.shape} and {b.shape}")
    return float(np.multiply(a, b, order="C").sum())


def norm(a: np.ndarray) -> float:
    """The Euclidean norm of a vector, sqrt(<a, a>) (its unit).

    Examples
    --------
    >>> norm(np.array([3.0, 4.0]))
    5.0
    """
    a = np.asarray(a, dtype=float).ravel()
    return float(np.sqrt(vdot(a, a)))


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` for vectors and matrices, in the fixed order.

    Parameters
    ----------
    a, b : numpy.ndarray
        Shapes (n,) or (m, n), and (n,) or (n, k); with a vector ``b``, ``a`` may have any
        number of leading axes, (..., n).

    Returns
    -------
    numpy.ndarray
        As ``a @ b``: a 0-d array for two vectors, (...,), (k,) or (m, k) otherwise.

    Examples
    --------
    >>> a = np.array([[1.0, 2.0], [3.0, 4.0]])
    >>> dot(a, np.array([1.0, 1.0]))
    array([3., 7.])
    >>> dot(np.array([1.0, 1.0]), a)
    array([4., 6.])
    >>> dot(a, a)
    array([[ 7., 10.],
           [15., 22.]])
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if (b.ndim == 2 and a.ndim > 2) or b.ndim not in (1, 2) or a.shape[-1] != b.shape[0]:
        raise ValueError(f"cannot multiply shapes {a.shape} and {b.shape}")
    if b.ndim == 1:
        return np.multiply(a, b, order="C").sum(axis=-1)
    bt = np.ascontiguousarray(b.T)  # (k, n): each output a sum along the last axis
    if a.ndim == 1:
        return np.multiply(bt, a, order="C").sum(axis=-1)
    m, n = a.shape
    out = np.empty((m, bt.shape[0]))
    rows = max(1, _BLOCK // max(1, n * bt.shape[0]))
    for lo in range(0, m, rows):
        block = a[lo : lo + rows]
        out[lo : lo + rows] = np.multiply(block[:, None, :], bt[None, :, :], order="C").sum(axis=-1)
    return out


def orthonormal_complement(u: np.ndarray) -> np.ndarray:
    """(K, K - 1): orthonormal columns spanning the directions orthogonal to ``u`` (K,), the
    last K - 1 columns of the Householder reflection that takes u to the first axis.

    Examples
    --------
    >>> q = orthonormal_complement(np.array([1.0, 1.0, 1.0]))
    >>> bool(np.allclose(q.T @ q, np.eye(2))), bool(np.allclose(q.T @ np.ones(3), 0.0))
    (True, True)
    """
    u = np.asarray(u, dtype=float)
    v = u / norm(u)
    v[0] += math.copysign(1.0, v[0])
    reflection = np.eye(u.size) - np.multiply.outer(v, v) * (2.0 / vdot(v, v))
    return np.ascontiguousarray(reflection[:, 1:])


def cov(x: np.ndarray) -> np.ndarray:
    """Sample covariance of the rows of ``x`` (observations in rows, ddof 1), as
    ``np.cov(x, rowvar=False)``.

    Examples
    --------
    >>> cov(np.array([[0.0, 1.0], [2.0, 5.0]]))
    array([[2., 4.],
           [4., 8.]])
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 2 or x.shape[0] < 2:
        raise ValueError(f"cov needs two or more rows of observations, got shape {x.shape}")
    c = x - x.mean(axis=0)
    return dot(c.T, c) / (x.shape[0] - 1)


def solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with ``a x = b``: Gaussian elimination with partial pivoting, then back
    substitution, as ``np.linalg.solve``.

    Parameters
    ----------
    a : numpy.ndarray
        (n, n), non-singular.
    b : numpy.ndarray
        (n,) or (n, k).

    Raises
    ------
    numpy.linalg.LinAlgError
        If a pivot is exactly zero (``a`` singular).

    Examples
    --------
    >>> solve(np.array([[0.0, 2.0], [4.0, 0.0]]), np.array([2.0, 8.0]))
    array([2., 1.])
    """
    a = np.array(a, dtype=float)  # copies: eliminated in place
    b = np.array(b, dtype=float)
    n = a.shape[0]
    if a.shape != (n, n) or b.shape[0] != n:
        raise ValueError(f"cannot solve a system of shapes {a.shape} and {b.shape}")
    vector = b.ndim == 1
    if vector:
        b = b[:, None]
    for col in range(n):
        pivot = col + int(np.argmax(np.abs(a[col:, col])))
        if a[pivot, col] == 0.0:
            raise np.linalg.LinAlgError("singular matrix")
        if pivot != col:
            a[[col, pivot]] = a[[pivot, col]]
            b[[col, pivot]] = b[[pivot, col]]
        factors = a[col + 1 :, col] / a[col, col]
        a[col + 1 :, col:] -= factors[:, None] * a[col, col:][None, :]
        b[col + 1 :] -= factors[:, None] * b[col][None, :]
    x = np.empty_like(b)
    for row in range(n - 1, -1, -1):
        rest = np.multiply(a[row, row + 1 :][:, None], x[row + 1 :]).sum(axis=0)
        x[row] = (b[row] - rest) / a[row, row]
    return x[:, 0] if vector else x


def cholesky(a: np.ndarray) -> np.ndarray:
    """The lower Cholesky factor L of a symmetric positive definite ``a`` = L L', as
    ``np.linalg.cholesky``.

    Raises
    ------
    numpy.linalg.LinAlgError
        If ``a`` is not positive definite.

    Examples
    --------
    >>> cholesky(np.array([[4.0, 2.0], [2.0, 5.0]]))
    array([[2., 0.],
           [1., 2.]])
    """
    a = np.asarray(a, dtype=float)
    n = a.shape[0]
    low = np.zeros_like(a)
    for j in range(n):
        pivot = a[j, j] - vdot(low[j, :j], low[j, :j])
        if not pivot > 0.0:
            raise np.linalg.LinAlgError("matrix is not positive definite")
        low[j, j] = np.sqrt(pivot)
        rest = np.multiply(low[j + 1 :, :j], low[j, :j], order="C").sum(axis=-1)
        low[j + 1 :, j] = (a[j + 1 :, j] - rest) / low[j, j]
    return low


def solve_lower(low: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with ``low x = b`` for lower triangular ``low``, by forward substitution; a stack
    of systems at once: ``low`` (..., n, n) and ``b`` (..., n) or (..., n, k).

    Examples
    --------
    >>> solve_lower(np.array([[2.0, 0.0], [1.0, 1.0]]), np.array([2.0, 3.0]))
    array([1., 2.])
    """
    low = np.asarray(low, dtype=float)
    b = np.asarray(b, dtype=float)
    vector = b.ndim == low.ndim - 1
    if vector:
        b = b[..., None]
    n = low.shape[-1]
    x = np.empty(np.broadcast_shapes(low.shape[:-2], b.shape[:-2]) + b.shape[-2:])
    for i in range(n):
        rest = np.multiply(low[..., i, :i, None], x[..., :i, :]).sum(axis=-2)
        x[..., i, :] = (b[..., i, :] - rest) / low[..., i, i, None]
    return x[..., 0] if vector else x


def inv(a: np.ndarray) -> np.ndarray:
    """The inverse of a non-singular square matrix (:func:`solve` of the identity).

    Examples
    --------
    >>> inv(np.array([[2.0, 0.0], [0.0, 4.0]]))
    array([[0.5 , 0.  ],
           [0.  , 0.25]])
    """
    a = np.asarray(a, dtype=float)
    return solve(a, np.eye(a.shape[0]))


def _qr(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Q' (K, L) and R (K, K) of ``a`` (L, K) = Q R, by modified Gram-Schmidt done twice
    (the second pass restores the orthogonality the first loses to rounding).

    Raises
    ------
    numpy.linalg.LinAlgError
        If a column is (numerically) a combination of the others.
    """
    q = np.ascontiguousarray(a.T, dtype=float)  # rows: a's columns, made orthonormal in place
    k = q.shape[0]
    r = np.zeros((k, k))
    for j in range(k):
        for _ in range(2):
            for i in range(j):
                c = vdot(q[i], q[j])
                r[i, j] += c
                q[j] = q[j] - c * q[i]
        norm = float(np.sqrt(vdot(q[j], q[j])))
        if norm <= 1e-13 * float(np.sqrt(vdot(a[:, j], a[:, j]))):
            raise np.linalg.LinAlgError(f"column {j} is a combination of the others")
        r[j, j] = norm
        q[j] = q[j] / norm
    return q, r


def _check_columns(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[0] < a.shape[1]:
        raise ValueError(f"need a matrix of at least as many rows as columns, got {a.shape}")
    return a


def lstsq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The least-squares solution of ``a x = b`` for ``a`` of full column rank, as
    ``np.linalg.lstsq(a, b)[0]``: a QR factorisation (modified Gram-Schmidt, twice), then
    back substitution.

    Parameters
    ----------
    a : numpy.ndarray
        (L, K), L >= K, columns linearly independent.
    b : numpy.ndarray
        (L,) or (L, C).

    Raises
    ------
    numpy.linalg.LinAlgError
        If a column is (numerically) a combination of the others.

    Examples
    --------
    >>> t = np.arange(4.0)
    >>> lstsq(np.column_stack((np.ones(4), t)), 1.0 + 2.0 * t)
    array([1., 2.])
    """
    a = _check_columns(a)
    b = np.asarray(b, dtype=float)
    if b.shape[0] != a.shape[0]:
        raise ValueError(f"cannot fit shapes {a.shape} and {b.shape} by least squares")
    q, r = _qr(a)
    return solve(r, dot(q, b))


def pinv(a: np.ndarray) -> np.ndarray:
    """The pseudo-inverse (K, L) of ``a`` (L, K) of full column rank, R^-1 Q': what
    :func:`lstsq` applies to ``b``.

    Examples
    --------
    >>> pinv(np.array([[2.0], [0.0]]))
    array([[0.5, 0. ]])
    """
    q, r = _qr(_check_columns(a))
    return solve(r, q)


def matrix_power(a: np.ndarray, n: int) -> np.ndarray:
    """``a`` to the integer power ``n >= 0`` by repeated squaring.

    Examples
    --------
    >>> matrix_power(np.array([[1.0, 1.0], [0.0, 1.0]]), 5)
    array([[1., 5.],
           [0., 1.]])
    """
    a = np.asarray(a, dtype=float)
    if n < 0:
        raise ValueError(f"the power must be >= 0, got {n}")
    out = np.eye(a.shape[0])
    square = a
    while n:
        if n & 1:
            out = dot(out, square)
        n >>= 1
        if n:
            square = dot(square, square)
    return out


#: Taylor terms of the exponential of a matrix scaled to a 1-norm of at most 1/2: the
#: remainder is below 0.5^19 / 19! ~ 1.6e-23 of the result, far below rounding.
_EXPM_TERMS = 18


def expm(a: np.ndarray) -> np.ndarray:
    """The matrix exponential e^a, by scaling and squaring: a / 2^s (1-norm <= 1/2) through
    a Taylor series of :data:`_EXPM_TERMS` terms (Horner), then squared s times.  As
    :func:`scipy.linalg.expm` to about 1e-15 for the well-scaled matrices of a
    discretisation (A dt).

    Examples
    --------
    >>> round(float(expm(np.array([[1.0]]))[0, 0]), 12)
    2.718281828459
    """
    a = np.asarray(a, dtype=float)
    norm = float(np.abs(a).sum(axis=0).max()) if a.size else 0.0
    s = 0
    while norm > 0.5:
        norm /= 2.0
        s += 1
    scaled = a / 2.0**s
    eye = np.eye(a.shape[0])
    out = eye.copy()
    for k in range(_EXPM_TERMS, 0, -1):  # I + x/1 (I + x/2 (I + ... (I + x/K)))
        out = eye + dot(scaled, out) / k
    for _ in range(s):
        out = dot(out, out)
    return out


def eigvals(a: np.ndarray) -> np.ndarray:
    """The eigenvalues of a small real square matrix, as ``np.linalg.eigvals``: balanced
    (rows and columns scaled by powers of two, which is exact), reduced to upper Hessenberg
    form by Gaussian elimination with pivoting, then Francis double-shift QR iterations
    (Wilkinson; Numerical Recipes' ``balanc``, ``elmhes`` and ``hqr``), all in Python floats
    in one order.  A complex pair comes as (positive imaginary part, negative), as LAPACK's.

    Meant for the state matrices of an aircraft (4 to 9 states): O(n^3) Python work.

    Raises
    ------
    numpy.linalg.LinAlgError
        If the QR iterations do not converge (30 per eigenvalue).

    Examples
    --------
    >>> eigvals(np.array([[0.0, 1.0], [-4.0, 0.0]]))
    array([0.+2.j, 0.-2.j])
    >>> sorted(eigvals(np.diag([3.0, -1.0, 2.0])).real.tolist())
    [-1.0, 2.0, 3.0]
    """
    m = [[float(v) for v in row] for row in np.asarray(a, dtype=float)]
    n = len(m)
    if any(len(row) != n for row in m):
        raise ValueError(f"eigvals needs a square matrix, got {np.shape(a)}")
    _balance(m)
    _hessenberg(m)
    return _hessenberg_eigvals(m)


def _balance(a: list[list[float]]) -> None:
    """Scale rows and columns by powers of two until their off-diagonal norms are alike."""
    n = len(a)
    done = False
    while not done:
        done = True
        for i in range(n):
            c = sum(abs(a[j][i]) for j in range(n) if j != i)
            r = sum(abs(a[i][j]) for j in range(n) if j != i)
            if c == 0.0 or r == 0.0:
                continue
            total, f = c + r, 1.0
            while c < r / 2.0:
                f, c = f * 2.0, c * 4.0
            while c > r * 2.0:
                f, c = f / 2.0, c / 4.0
            if (c + r) / f < 0.95 * total:
                done = False
                for j in range(n):
                    a[i][j] /= f
                    a[j][i] *= f


def _hessenberg(a: list[list[float]]) -> None:
    """Reduce to upper Hessenberg form in place (similar to the input), by elimination with
    the largest pivot; the entries below the subdiagonal are set to zero."""
    n = len(a)
    for m in range(1, n - 1):
        x, i = 0.0, m
        for j in range(m, n):
            if abs(a[j][m - 1]) > abs(x):
                x, i = a[j][m - 1], j
        if i != m:
            a[i], a[m] = a[m], a[i]
            for row in a:
                row[i], row[m] = row[m], row[i]
        if x == 0.0:
            continue
        for i in range(m + 1, n):
            y = a[i][m - 1]
            if y == 0.0:
                continue
            y /= x
            a[i][m - 1] = 0.0
            for j in range(m, n):
                a[i][j] -= y * a[m][j]
            for j in range(n):
                a[j][m] += y * a[j][i]


def _hessenberg_eigvals(a: list[list[float]]) -> np.ndarray:
    """The eigenvalues of an upper Hessenberg matrix (destroyed): double-shift QR."""
    n = len(a)
    wr, wi = [0.0] * n, [0.0] * n
    norm = sum(abs(a[i][j]) for i in range(n) for j in range(max(i - 1, 0), n))
    nn, t = n - 1, 0.0
    its = 0
    while nn >= 0:
        low = nn  # the active block is low .. nn: look for a negligible subdiagonal
        while low >= 1:
            s = abs(a[low - 1][low - 1]) + abs(a[low][low])
            if s == 0.0:
                s = norm
            if abs(a[low][low - 1]) + s == s:
                a[low][low - 1] = 0.0
                break
            low -= 1
        x = a[nn][nn]
        if low == nn:  # one root
            wr[nn], wi[nn] = x + t, 0.0
            nn, its = nn - 1, 0
            continue
        y, w = a[nn - 1][nn - 1], a[nn][nn - 1] * a[nn - 1][nn]
        if low == nn - 1:  # two roots
            p = 0.5 * (y - x)
            q = p * p + w
            z = math.sqrt(abs(q))
            x += t
            if q >= 0.0:  # a real pair
                z = p + math.copysign(z, p)
                wr[nn - 1] = wr[nn] = x + z
                if z:
                    wr[nn] = x - w / z
                wi[nn - 1] = wi[nn] = 0.0
            else:  # a complex pair
                wr[nn - 1] = wr[nn] = x + p
                wi[nn - 1], wi[nn] = z, -z
            nn, its = nn - 2, 0
            continue
        if its == 30:
            raise np.linalg.LinAlgError("eigenvalues did not converge")
        if its in (10, 20):  # an exceptional shift
            t += x
            for i in range(nn + 1):
                a[i][i] -= x
            s = abs(a[nn][nn - 1]) + abs(a[nn - 1][nn - 2])
            x = y = 0.75 * s
            w = -0.4375 * s * s
        its += 1
        m, p, q, r = _shift_start(a, low, nn, x, y, w)
        _double_qr_step(a, low, m, nn, (p, q, r))
    return np.array([complex(re, im) for re, im in zip(wr, wi, strict=True)])


def _shift_start(
    a: list[list[float]], low: int, nn: int, x: float, y: float, w: float
) -> tuple[int, float, float, float]:
    """Where the double shift (from x, y and w) starts: the row m of two consecutive small
    subdiagonal elements, and the first column of the shifted product there (p, q, r)."""
    m = nn - 2
    while True:
        z = a[m][m]
        r, s = x - z, y - z
        p = (r * s - w) / a[m + 1][m] + a[m][m + 1]
        q = a[m + 1][m + 1] - z - r - s
        r = a[m + 2][m + 1]
        s = abs(p) + abs(q) + abs(r)
        p, q, r = p / s, q / s, r / s
        if m == low:
            return m, p, q, r
        u = abs(a[m][m - 1]) * (abs(q) + abs(r))
        v = abs(p) * (abs(a[m - 1][m - 1]) + abs(z) + abs(a[m + 1][m + 1]))
        if u + v == v:
            return m, p, q, r
        m -= 1


def _double_qr_step(
    a: list[list[float]], low: int, m: int, nn: int, first: tuple[float, float, float]
) -> None:
    """One Francis double-shift QR step on rows low .. nn from row m, by Householder
    reflections of three rows, the first from the shifted product's column ``first``."""
    p, q, r = first
    x = y = z = 0.0
    for i in range(m + 2, nn + 1):
        a[i][i - 2] = 0.0
        if i != m + 2:
            a[i][i - 3] = 0.0
    for k in range(m, nn):
        if k != m:
            p, q = a[k][k - 1], a[k + 1][k - 1]
            r = a[k + 2][k - 1] if k != nn - 1 else 0.0
            x = abs(p) + abs(q) + abs(r)
            if x != 0.0:
                p, q, r = p / x, q / x, r / x
        s = math.copysign(math.sqrt(p * p + q * q + r * r), p)
        if s == 0.0:
            continue
        if k == m:
            if low != m:
                a[k][k - 1] = -a[k][k - 1]
        else:
            a[k][k - 1] = -s * x
        p += s
        x, y, z = p / s, q / s, r / s
        q, r = q / p, r / p
        for j in range(k, nn + 1):
            p = a[k][j] + q * a[k + 1][j]
            if k != nn - 1:
                p += r * a[k + 2][j]
                a[k + 2][j] -= p * z
            a[k + 1][j] -= p * y
            a[k][j] -= p * x
        for i in range(low, min(nn, k + 3) + 1):
            p = x * a[i][k] + y * a[i][k + 1]
            if k != nn - 1:
                p += z * a[i][k + 2]
                a[i][k + 2] -= p * r
            a[i][k + 1] -= p * q
            a[i][k] -= p
