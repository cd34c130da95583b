"""Modular helpers of the joint visits: reduced rows, the columns a kernel leaves undetermined, an
expression's value mod p.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import sympy as sp

from obsnl.algebra.modp import nmod_matrix, nullspace_mod_p

__all__ = ["kernel_rows"]


# --------------------------------------------------------------------------- modular helpers
def _rref(R: np.ndarray, p: int) -> np.ndarray:
    if R.shape[0] == 0 or R.shape[1] == 0:
        return np.zeros((0, R.shape[1]), dtype=np.int64)
    X, r = nmod_matrix(R, R.shape[1], p).rref()
    return np.array([[int(X[i, j]) for j in range(R.shape[1])] for i in range(r)], dtype=np.int64)


def kernel_rows(R: np.ndarray, ncols: int, p: int) -> list[bool]:
    """Per column: True when some kernel vector of ``R`` is nonzero there (not determined).

    Parameters
    ----------
    R : numpy.ndarray
        Integer rows mod ``p`` (may have no rows).
    ncols : int
        Number of columns.
    p : int
        Prime modulus.

    Returns
    -------
    list of bool
    """
    if ncols == 0:
        return []
    ker = nullspace_mod_p(R, ncols, p) if R.shape[0] else [[int(i == j) for i in range(ncols)] for j in range(ncols)]
    return [any(k[j] for k in ker) for j in range(ncols)]


def _mod(expr: sp.Expr, values: Mapping[sp.Symbol, int], p: int) -> int | None:
    """``expr`` at integer ``values`` reduced mod p (None: not a rational number, or a zero denominator)."""
    v = sp.sympify(expr).xreplace({s: sp.Integer(values[s]) for s in expr.free_symbols if s in values})
    if not v.is_Rational:
        return None
    v = sp.Rational(v)
    if int(v.q) % p == 0:
        return None
    return int(v.p) * pow(int(v.q), -1, p) % p
