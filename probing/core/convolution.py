"""Causal convolution by FFT: the response of a linear system from rest.

:func:`scipy.signal.fftconvolve` does the same, but importing ``scipy.signal`` takes most of
a second (and more in a sweep worker, which pays it once per process); ``scipy.fft`` is
already loaded by the correlator.  The tests check this against ``fftconvolve``.
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

__all__ = ["causal_convolve"]


def causal_convolve(u: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """The first ``len(u)`` samples of the convolution of ``u`` with ``kernel``.

    Parameters
    ----------
    u : numpy.ndarray
        Input, shape (N,).
    kernel : numpy.ndarray
        Impulse response, shape (K,) or (K, C) for C outputs at once.

    Returns
    -------
    numpy.ndarray
        y[k] = sum_j kernel[j] u[k - j] for k < N; shape (N,) or (N, C).

    Examples
    --------
    >>> causal_convolve(np.array([1.0, 0.0, 2.0]), np.array([1.0, 0.5]))
    array([1. , 0.5, 2. ])
    """
    u = np.asarray(u, dtype=float)
    kernel = np.asarray(kernel, dtype=float)
    n = u.size
    if n == 0 or kernel.shape[0] == 0:
        return np.zeros((n, *kernel.shape[1:]))
    kernel = kernel[:n]  # later taps never reach the first n samples
    size = sfft.next_fast_len(n + kernel.shape[0] - 1, real=True)
    spec_u = sfft.rfft(u, size)
    spec_k = sfft.rfft(kernel, size, axis=0)
    if kernel.ndim > 1:
        spec_u = spec_u[:, None]
    return sfft.irfft(spec_u * spec_k, size, axis=0)[:n]
