"""Progress of long work, shown from Python and from the command line alike.

:class:`Progress` is what a long function takes as its ``progress`` argument, resolved once: ``True`` a
tqdm bar on standard error (started at the first step, so that a refusal before any work prints nothing
else), ``False``/``None`` nothing, a callable called at each step (a user's own counter or bar).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

__all__ = ["Progress"]


class Progress:
    """Steps of one long task.

    Parameters
    ----------
    progress : bool, callable or None
        ``True``: a tqdm bar on standard error; ``False`` or None: nothing; a callable: called at each
        step (with no argument, or with the step count when ``counted``).
    total : int or None
        Steps expected (None: unknown).
    desc, unit : str
        The bar's label and unit.
    counted : bool
        Call a user's callable with the number of steps (default: with no argument).

    Examples
    --------
    >>> seen = []
    >>> with Progress(seen.append, 3, "sets", counted=True) as step:
    ...     step(); step(2)
    >>> seen
    [1, 2]
    >>> with Progress(False, 3, "sets") as step:
    ...     step()
    """

    def __init__(
        self,
        progress: bool | Callable[..., Any] | None,
        total: int | None,
        desc: str,
        unit: str = "step",
        *,
        counted: bool = False,
    ) -> None:
        self._user = progress if callable(progress) else None
        self._show = progress is True
        self._total, self._desc, self._unit, self._counted = total, desc, unit, counted
        self._bar: Any = None

    def __call__(self, n: int = 1) -> None:
        """Count ``n`` steps done."""
        if self._user is not None:
            if self._counted:
                self._user(n)
            else:
                for _ in range(n):
                    self._user()
        elif self._show:
            if self._bar is None:
                try:
                    from tqdm import tqdm
                except ImportError:  # pragma: no cover  (tqdm is a dependency)
                    self._show = False
                    return
                self._bar = tqdm(desc=self._desc, total=self._total, unit=self._unit, file=sys.stderr)
            self._bar.update(n)

    def close(self) -> None:
        """End the bar (if one was shown)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
