"""Model: the one immutable model value, how it is read, and how it splits into smooth branches.

Its inner order, lowest first (a module imports only what stands below it, or its own sub-room):

1. ``bounds/``: bounded work (expression sizes, exact digits, text sizes) and the time budget;
2. ``reading/``: the text of a model: expressions, names, LaTeX names, unknown-input derivatives, and
   every field of a model read and checked with them;
3. ``core`` (the frozen :class:`~obsnl.model.core.Model`), then ``files`` (model files, the catalogue);
4. ``branching/``: switching functions, feasibility of sign patterns, the smooth branches, their
   representatives and the model's signature for a branch table.

May import: ``errors``, ``_text``. Must never import any other room of obsnl.
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "Model": "core",
    "read_model": "files",
    "model_to_toml": "files",
    "catalogue_path": "files",
    "Branch": "branching.branches",
    "split_branches": "branching.branches",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.model.branching.branches import Branch as Branch
    from obsnl.model.branching.branches import split_branches as split_branches
    from obsnl.model.core import Model as Model
    from obsnl.model.files import (
        catalogue_path as catalogue_path,
    )
    from obsnl.model.files import (
        model_to_toml as model_to_toml,
    )
    from obsnl.model.files import (
        read_model as read_model,
    )

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
