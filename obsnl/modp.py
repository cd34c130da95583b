"""Exact vectorised arithmetic modulo a prime ``p < 2**50`` on int64 numpy arrays.

Three pieces used by the randomized observability test:

- :func:`mulmod`: elementwise ``a*b mod p``. The int64 product wraps modulo ``2**64``; a quotient
  estimate from a float64 product (relative error below ``2**-50``) leaves a remainder
  ``|a*b - q*p| < 2**53``, which the wrapped int64 arithmetic therefore gives exactly.
- :class:`MatMod`: ``A @ B mod p`` for a matrix ``A`` fixed over many products. Both factors are
  split into 25-bit limbs, so that every limb product is below ``2**50`` and a sum of up to
  ``2**13`` of them stays below ``2**63``: int64 matrix products are exact.
- :class:`Echelon`: an incremental reduced row echelon basis (rank after every new row, and the
  kernel classification of the columns at the end) without converting to another library.

No float ever decides anything: floats only estimate quotients that integer arithmetic corrects.
"""

from __future__ import annotations

import numpy as np

__all__ = ["mulmod", "MatMod", "Echelon", "LIMB"]

LIMB = 25
_MASK = (1 << LIMB) - 1


def mulmod(a: np.ndarray, b: np.ndarray, p: int) -> np.ndarray:
    """Elementwise ``a*b mod p`` (broadcasting) for int64 ``a, b`` in ``[0, p)``, exact.

    Examples
    --------
    >>> import numpy as np
    >>> p = 2**49 + 9  # any modulus below 2**50
    >>> mulmod(np.array([p - 1, 3]), np.array([p - 1, 5]), p).tolist()
    [1, 15]
    """
    q = (np.multiply(a, b, dtype=np.float64) * (1.0 / p)).astype(np.int64)
    r = a * b - q * p
    return r % p


class MatMod:
    """A fixed matrix ``A`` (entries in ``[0, p)``) ready for exact products ``A @ B mod p``.

    Parameters
    ----------
    A
        int64 matrix of shape ``(m, n)`` with ``n < 2**13``.
    p
        The modulus, below ``2**50``.
    """

    def __init__(self, A: np.ndarray, p: int) -> None:
        A = np.asarray(A, dtype=np.int64)
        if A.ndim != 2 or A.shape[1] >= 1 << 13:
            raise ValueError("MatMod needs a matrix with fewer than 2**13 columns")
        self.p = p
        self.shape = A.shape
        m = A.shape[0]
        self._m = m
        # [A_hi; A_lo] stacked: one int64 product gives all four limb products
        self._stack = np.vstack([A >> LIMB, A & _MASK])
        self._c25 = np.int64((1 << LIMB) % p)
        self._c50 = np.int64((1 << (2 * LIMB)) % p)

    def __matmul__(self, B: np.ndarray) -> np.ndarray:
        """``A @ B mod p`` for int64 ``B`` in ``[0, p)`` (a vector or a matrix)."""
        p = self.p
        vec = B.ndim == 1
        if vec:
            B = B[:, None]
        c = B.shape[1]
        P = self._stack @ np.concatenate((B >> LIMB, B & _MASK), axis=1)  # (2m, 2c), entries < 2**56
        m = self._m
        mid = (P[:m, c:] + P[m:, :c]) % p  # hi*lo + lo*hi
        out = (mulmod(P[:m, :c] % p, self._c50, p) + mulmod(mid, self._c25, p) + P[m:, c:]) % p
        return out[:, 0] if vec else out


class Echelon:
    """Reduced row echelon basis over GF(p), grown one row at a time.

    ``add(row)`` returns True when the row raised the rank. :meth:`unobservable` gives, per column,
    whether some kernel vector is nonzero there (an unknown that the rows do not determine).

    Examples
    --------
    >>> import numpy as np
    >>> e = Echelon(3, 101)
    >>> e.add(np.array([1, 2, 0])), e.add(np.array([2, 4, 0])), e.add(np.array([0, 0, 5]))
    (True, False, True)
    >>> e.rank, e.unobservable()
    (2, [True, True, False])
    """

    def __init__(self, ncols: int, p: int) -> None:
        self.p = p
        self.ncols = ncols
        self.rows = np.zeros((0, ncols), dtype=np.int64)
        self.pivots: list[int] = []

    @property
    def rank(self) -> int:
        return len(self.pivots)

    def add(self, row: np.ndarray) -> bool:
        p = self.p
        v = np.asarray(row, dtype=np.int64) % p
        if self.pivots:
            coef = v[self.pivots]
            if coef.any():
                v = (v - mulmod(coef[:, None], self.rows, p).sum(axis=0)) % p
        nz = np.flatnonzero(v)
        if nz.size == 0:
            return False
        j = int(nz[0])
        v = mulmod(v, np.int64(pow(int(v[j]), -1, p)), p)
        if self.pivots:
            col = self.rows[:, j]
            if col.any():
                self.rows = (self.rows - mulmod(col[:, None], v[None, :], p)) % p
        self.rows = np.vstack([self.rows, v[None, :]])
        self.pivots.append(j)
        return True

    def unobservable(self) -> list[bool]:
        """Per column: True when a kernel vector of the rows is nonzero there."""
        free = [j for j in range(self.ncols) if j not in set(self.pivots)]
        out = [True] * self.ncols
        for i, j in enumerate(self.pivots):
            out[j] = bool(free) and bool(self.rows[i, free].any())
        return out
