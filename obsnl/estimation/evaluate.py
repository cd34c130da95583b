"""Evaluate a casadi Function on numpy arrays without converting through casadi matrices.

A filter run over a record returns about half a million numbers (the covariance at every sample);
casadi's usual call turns each into a Python float on the way out, which took about a fifth of a
seed-experiment pass. :func:`call` binds caller-owned numpy buffers to the Function instead
(casadi's ``Function.buffer``): the same compiled code on the same inputs, so the numbers are the
same, bit for bit, as those of ``fn(*args)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi as ca
import numpy as np

from obsnl.errors import EstimatorError

__all__ = ["call"]


def _dense_input(fn: ca.Function, i: int, value: Any) -> np.ndarray:
    shape = fn.size_in(i)
    arr = np.asarray(value, float)
    if arr.size != shape[0] * shape[1]:
        raise EstimatorError(f"input {fn.name_in(i)!r} of {fn.name()!r} needs {shape[0]}x{shape[1]} values, "
                             f"got shape {arr.shape}")
    if arr.ndim == 2 and arr.shape != shape and 1 not in shape:
        raise EstimatorError(f"input {fn.name_in(i)!r} of {fn.name()!r} needs shape {shape}, got {arr.shape}")
    return arr.reshape(shape, order="F") if arr.ndim < 2 else arr


def call(fn: ca.Function, args: Sequence[Any]) -> list[np.ndarray]:
    """``fn(*args)`` as dense numpy arrays (one per output, in casadi's shapes).

    Every input must be given in full (no broadcasting); an input with a sparse pattern falls back
    to casadi's usual call.

    Parameters
    ----------
    fn : casadi.Function
        The function.
    args : sequence of array_like
        One value per input, of the input's shape (a vector may be 1-D).

    Returns
    -------
    list of numpy.ndarray

    Raises
    ------
    EstimatorError
        A wrong size, or the evaluation failed.

    Examples
    --------
    >>> import casadi as ca
    >>> x = ca.SX.sym("x", 2)
    >>> f = ca.Function("f", [x], [ca.vertcat(x[0] * x[1], x[0] + 1)])
    >>> call(f, [[2.0, 3.0]])[0].ravel().tolist()
    [6.0, 3.0]
    """
    if len(args) != fn.n_in():
        raise EstimatorError(f"{fn.name()!r} takes {fn.n_in()} inputs, got {len(args)}")
    if not all(fn.sparsity_in(i).is_dense() for i in range(fn.n_in())):
        return [np.asarray(o) for o in fn(*args)]
    flat = [np.ascontiguousarray(_dense_input(fn, i, a).reshape(-1, order="F")) for i, a in enumerate(args)]
    nz = [np.zeros(fn.nnz_out(j)) for j in range(fn.n_out())]
    buf, evaluate = fn.buffer()
    for i, a in enumerate(flat):  # the arrays stay referenced until the evaluation is done
        buf.set_arg(i, memoryview(a))
    for j, r in enumerate(nz):
        buf.set_res(j, memoryview(r))
    evaluate()
    if buf.ret() != 0:
        raise EstimatorError(f"the evaluation of {fn.name()!r} failed (return code {buf.ret()})")
    out = []
    for j, r in enumerate(nz):
        sp = fn.sparsity_out(j)
        if sp.is_dense():
            out.append(np.ascontiguousarray(r.reshape(sp.shape, order="F")))  # row-major, as casadi's own conversion
        else:
            full = np.zeros(sp.shape)
            rows, cols = sp.get_triplet()
            full[np.asarray(rows, int), np.asarray(cols, int)] = r
            out.append(full)
    return out
