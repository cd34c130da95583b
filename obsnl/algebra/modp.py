"""Exact arithmetic modulo a prime: scalars, int64 arrays, ranks, kernels, rational reconstruction.

One module for every modular computation of the package (the engines and the symmetry side):

- :class:`Field`: GF(p) scalars (inverses, rationals in and out, ``q``-th roots); any prime below
  ``2**63``. :class:`Resample` says the random point hit a zero denominator or a non-residue.
- :func:`mulmod`: elementwise ``a*b mod p`` on int64 arrays for ``p < 2**50``. The int64 product wraps
  modulo ``2**64``; a quotient estimate from a float64 product (relative error below ``2**-50``) leaves
  a remainder ``|a*b - q*p| < 2**53``, which the wrapped int64 arithmetic therefore gives exactly.
- :class:`MatMod`: ``A @ B mod p`` for a matrix ``A`` fixed over many products. Both factors are
  split into 25-bit limbs, so that every limb product is below ``2**50`` and a sum of up to
  ``2**13`` of them stays below ``2**63``: int64 matrix products are exact.
- :class:`Echelon`: an incremental reduced row echelon basis (rank after every new row, and the
  kernel classification of the columns at the end) without converting to another library.
- :func:`rank_mod_p`, :func:`nullspace_mod_p`, :func:`rref_mod_p`, :func:`kernel_support`: rank, a kernel basis,
  the reduced rows of a whole matrix (flint), and the columns its kernel leaves undetermined.
- :func:`value_mod_p`: a sympy expression's value at integer values, in GF(p).
- :func:`rational_reconstruction`: back from GF(p) to a small rational.

No float ever decides anything: floats only estimate quotients that integer arithmetic corrects.
The engines draw a random prime below ``2**50`` for every run (:func:`random_prime`, array
arithmetic); :data:`PRIME` is the fixed prime of the computations without arrays (``same_field``,
the determining equations of the symmetry search), large for rational reconstruction.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import sympy as sp

__all__ = [
    "PRIME",
    "PRIME_BITS",
    "Field",
    "Resample",
    "random_prime",
    "mulmod",
    "MatMod",
    "Echelon",
    "LIMB",
    "nmod_matrix",
    "rank_mod_p",
    "nullspace_mod_p",
    "rref_mod_p",
    "kernel_support",
    "value_mod_p",
    "rational_reconstruction",
]

#: Bits of the engines' random primes (array products need ``p < 2**50``).
PRIME_BITS = 50
#: The fixed prime of the computations without arrays (62 bits, so that flint's nmod types hold it).
PRIME = 2**62 - 57
LIMB = 25
_MASK = (1 << LIMB) - 1


class Resample(Exception):
    """The random point (or prime) hit a zero denominator or a non-residue; draw another."""


@dataclass(frozen=True)
class Field:
    """GF(p) for a prime ``2 < p < 2**63``: exact scalar inverses, rationals and roots.

    Examples
    --------
    >>> F = Field(101)
    >>> F.inv(2), F.el(Fraction(1, 2)), F.rational(51), F.root(4, 2) in (2, 99)
    (51, 51, 1/2, True)
    """

    p: int

    def __post_init__(self) -> None:
        if not 2 < self.p < 2**63:
            raise ValueError("prime must be below 2**63")

    def inv(self, x: int) -> int:
        x = int(x) % self.p
        if x == 0:
            raise Resample("division by zero")
        return pow(x, -1, self.p)

    def el(self, c: Any) -> int:
        """The element of a rational number (a sympy Rational, a Fraction or an int)."""
        if hasattr(c, "q"):  # sympy
            return int(c.p) % self.p * self.inv(int(c.q)) % self.p
        c = Fraction(c)
        return c.numerator % self.p * self.inv(c.denominator) % self.p

    def rational(self, a: int) -> sp.Rational | None:
        """The small rational with this element (see :func:`rational_reconstruction`), or None."""
        return rational_reconstruction(a, self.p)

    def root(self, x: int, q: int) -> int:
        """A q-th root of x in GF(p) (Resample when there is none)."""
        x = int(x) % self.p
        if x == 0:
            raise Resample("root of zero")
        h = (self.p - 1) // 2
        if self.p % 4 == 3 and math.gcd(q, h) == 1 and pow(x, h, self.p) == 1:
            # the one root that is a square: the squares form a group of odd order h, on which
            # r -> r**q is a bijection; so roots of one number of different degrees agree
            return pow(x, pow(q, -1, h), self.p)
        g = math.gcd(q, self.p - 1)
        if g == 1:
            return pow(x, pow(q, -1, self.p - 1), self.p)
        if q == 2:
            from flint import nmod

            if pow(x, (self.p - 1) // 2, self.p) != 1:
                raise Resample("non-residue")
            return int(nmod(x, self.p).sqrt())
        from sympy.ntheory import nthroot_mod

        r = nthroot_mod(x, q, self.p)
        if r is None:
            raise Resample("non-residue")
        return int(r)


def random_prime(rng: random.Random, bits: int = PRIME_BITS) -> int:
    """A random prime in [2**(bits-1), 2**bits).

    Parameters
    ----------
    rng : random.Random
        Source of randomness.
    bits : int
        Bit length of the prime.

    Returns
    -------
    int
    """
    import sympy as sp

    lo = 2 ** (bits - 1)
    start = rng.randrange(lo, 2**bits - 2**20)
    return int(sp.nextprime(start))


def mulmod(a: np.ndarray | np.integer, b: np.ndarray | np.integer, p: int) -> np.ndarray:
    """Elementwise ``a*b mod p`` (broadcasting) for int64 ``a, b`` in ``[0, p)``, exact.

    Parameters
    ----------
    a, b : numpy.ndarray or numpy.integer
        int64 arrays (or scalars, broadcast) with entries in ``[0, p)``.
    p : int
        Modulus, below ``2**50``.

    Returns
    -------
    numpy.ndarray
        int64 residues in ``[0, p)``.

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
    A : ndarray
        int64 matrix of shape ``(m, n)`` with ``n < 2**13``.
    p : int
        The modulus, below ``2**50``.
    """

    def __init__(self, A: np.ndarray, p: int) -> None:
        A = np.asarray(A, dtype=np.int64)
        if p >= 2**PRIME_BITS:
            raise ValueError(f"MatMod needs a prime below 2**{PRIME_BITS}")
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


# --------------------------------------------------------------------------- whole matrices (flint)
def nmod_matrix(rows: np.ndarray | Sequence[Sequence[int]], ncols: int, p: int) -> Any:
    """``rows`` (an int64 array or lists of integers) as a flint ``nmod_mat`` modulo ``p``.

    Parameters
    ----------
    rows : numpy.ndarray or sequence of sequence of int
        Matrix rows.
    ncols : int
        Number of columns.
    p : int
        Modulus.

    Returns
    -------
    flint.nmod_mat
    """
    from flint import nmod_mat

    rows = rows.tolist() if isinstance(rows, np.ndarray) else rows
    return nmod_mat(len(rows), ncols, [int(x) for r in rows for x in r], p)


def rank_mod_p(rows: np.ndarray | Sequence[Sequence[int]], ncols: int, p: int = PRIME) -> int:
    """Rank of an integer matrix modulo ``p``.

    Parameters
    ----------
    rows : numpy.ndarray or sequence of sequence of int
        Matrix rows (may be empty).
    ncols : int
        Number of columns.
    p : int
        Prime modulus.

    Returns
    -------
    int

    Examples
    --------
    >>> rank_mod_p([[1, 2], [2, 4]], 2), rank_mod_p([[1, 2], [2, 4]], 2, p=3)
    (1, 1)
    """
    if len(rows) == 0 or ncols == 0:
        return 0
    return nmod_matrix(rows, ncols, p).rank()


def nullspace_mod_p(rows: np.ndarray | Sequence[Sequence[int]], ncols: int, p: int = PRIME) -> list[list[int]]:
    """A basis of the right kernel ``{x : rows x = 0}`` mod ``p`` (rref-normalised), as lists.

    Parameters
    ----------
    rows : numpy.ndarray or sequence of sequence of int
        Matrix rows (may be empty: the kernel is everything).
    ncols : int
        Number of columns.
    p : int
        Prime modulus.

    Returns
    -------
    list of list of int
        Basis vectors of length ``ncols``, residues mod ``p``.

    Examples
    --------
    >>> nullspace_mod_p([[1, 2, 0]], 3, p=7)
    [[5, 1, 0], [0, 0, 1]]
    """
    if ncols == 0:
        return []
    if len(rows) == 0:
        return [[int(i == j) for i in range(ncols)] for j in range(ncols)]
    X, nullity = nmod_matrix(rows, ncols, p).nullspace()
    if not nullity:
        return []
    table = X.tolist()
    return [[int(table[i][j]) for i in range(ncols)] for j in range(nullity)]


def rref_mod_p(rows: np.ndarray, p: int) -> np.ndarray:
    """The nonzero rows of the reduced row echelon form of an integer matrix modulo ``p``.

    Parameters
    ----------
    rows : numpy.ndarray
        Integer matrix rows (may have no rows or no columns).
    p : int
        Prime modulus.

    Returns
    -------
    numpy.ndarray
        ``(rank, ncols)`` int64, residues mod ``p``.

    Examples
    --------
    >>> rref_mod_p(np.array([[2, 4, 1], [1, 2, 0]]), 7).tolist()
    [[1, 2, 0], [0, 0, 1]]
    """
    if rows.shape[0] == 0 or rows.shape[1] == 0:
        return np.zeros((0, rows.shape[1]), dtype=np.int64)
    X, r = nmod_matrix(rows, rows.shape[1], p).rref()
    return np.array([[int(X[i, j]) for j in range(rows.shape[1])] for i in range(r)], dtype=np.int64)


def kernel_support(rows: np.ndarray, ncols: int, p: int) -> list[bool]:
    """Per column: True when some kernel vector of ``rows`` is nonzero there, an unknown the rows leave undetermined
    (as :meth:`Echelon.unobservable`, for a whole matrix).

    Parameters
    ----------
    rows : numpy.ndarray
        Integer rows mod ``p`` (may have no rows: then every column is undetermined).
    ncols : int
        Number of columns.
    p : int
        Prime modulus.

    Returns
    -------
    list of bool

    Examples
    --------
    >>> kernel_support(np.array([[1, 2, 0]]), 3, 7)
    [True, True, True]
    >>> kernel_support(np.array([[1, 2, 0], [0, 0, 1]]), 3, 7)
    [True, True, False]
    """
    ker = nullspace_mod_p(rows, ncols, p)  # no rows: every unit vector
    return [any(k[j] for k in ker) for j in range(ncols)]


def value_mod_p(expr: sp.Expr, values: Mapping[sp.Symbol, int], p: int) -> int | None:
    """``expr`` at the integer ``values`` of its symbols, reduced mod ``p``; None when the value is not a rational
    number (a symbol without a value, a transcendental function) or its denominator vanishes mod ``p``.

    Parameters
    ----------
    expr : sympy.Expr
        The expression.
    values : mapping of sympy.Symbol to int
        Integer values of (some of) its symbols.
    p : int
        Prime modulus.

    Returns
    -------
    int or None

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> value_mod_p(x / 3 + 1, {x: 2}, 7), value_mod_p(x / 7, {x: 1}, 7), value_mod_p(x + y, {x: 1}, 7)
    (4, None, None)
    """
    import sympy as sp

    v = sp.sympify(expr).xreplace({s: sp.Integer(values[s]) for s in expr.free_symbols if s in values})
    if not v.is_Rational:
        return None
    v = sp.Rational(v)
    if int(v.q) % p == 0:
        return None
    return int(v.p) * pow(int(v.q), -1, p) % p


def rational_reconstruction(a: int, p: int = PRIME) -> sp.Rational | None:
    """The rational ``n/d`` with ``n = a d mod p`` and ``|n|, d <= sqrt(p/2)`` (a sympy Rational), or None.

    Parameters
    ----------
    a : int
        A residue mod ``p``.
    p : int
        Prime modulus.

    Returns
    -------
    sympy.Rational or None
        None when no fraction within the bound maps to ``a``.

    Examples
    --------
    >>> rational_reconstruction(3 * pow(7, -1, PRIME) % PRIME)
    3/7
    """
    import sympy as sp

    a %= p
    bound = math.isqrt(p // 2)
    r0, r1, t0, t1 = p, a, 0, 1
    while r1 > bound:
        q = r0 // r1
        r0, r1 = r1, r0 - q * r1
        t0, t1 = t1, t0 - q * t1
    if t1 == 0 or abs(t1) > bound:
        return None
    return sp.Rational(r1 * (1 if t1 > 0 else -1), abs(t1))
