"""A fit with as many unknowns as output samples measured is refused before any work (issue 41).

The fit of ``obsnl.identify`` estimates every parameter and every initial state; with 20 samples for 22 unknowns it
can pass through every sample, so no noise level, std or interval can come from it (a count, derived here), and the
advice to try other initial guesses cannot help. The refusal comes after the structural analysis (a model that no
record can identify is named first, as before) and before the noise levels, the filter and the fit (measured by the
CPU time of the call), and says what to change.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

import obsnl
from obsnl.errors import DataError

# x'' = u - sum_k p_k x^k v^(k % 2): 20 parameters, 2 states (x, v): 22 unknowns of the fit
_TERMS = " - ".join(f"p{k}*x**{k // 2}*v**{k % 2}" for k in range(20))
WIDE = obsnl.Model(name="wide", states=["x", "v"], parameters=[f"p{k}" for k in range(20)], inputs=["u"],
                   equations={"x": "v", "v": f"u - {_TERMS}"}, outputs={"y": "x"},
                   guess={f"p{k}": 1.0 for k in range(20)})


def _record(n: int) -> dict[str, np.ndarray]:
    t = np.arange(n) * 0.05
    return {"t": t, "u": np.sin(2.0 * t), "y": 0.1 * np.sin(2.0 * t - 0.3)}


def test_twenty_samples_for_twenty_two_unknowns_are_refused_before_the_filter():
    t0 = time.process_time()
    with pytest.raises(DataError) as info:
        obsnl.identify(WIDE, _record(20), noise={"u": 1e-3, "y": 1e-3}, progress=False, jit=False)
    text = str(info.value)
    assert text.startswith("22 unknowns (20 parameters, 2 initial states) against 20 output samples measured")
    assert "give a record of more than 22 output samples" in text and "\n" not in text
    assert "initial guesses" not in text  # no advice that cannot help
    assert time.process_time() - t0 < 5.0  # the structural analysis (0.1 s here), then a count: no filter, no fit


def test_missing_output_samples_do_not_count():
    # 25 samples, 4 of them missing: 21 measured against 22 unknowns
    cols = _record(25)
    cols["y"][[3, 9, 15, 21]] = np.nan
    assert np.sum(np.isfinite(cols["y"])) == 21
    with pytest.raises(DataError, match=r"^22 unknowns \(20 parameters, 2 initial states\) against 21 output samples"):
        obsnl.identify(WIDE, cols, noise={"u": 1e-3, "y": 1e-3}, progress=False, jit=False)
