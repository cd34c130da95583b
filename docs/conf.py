"""Sphinx configuration of obsnl's documentation.

Build (warnings are errors; the tutorials run):

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The API reference is written at each build from the package's own lists of public names (``obsnl.__all__`` and
each room's ``__all__``, see :data:`ROOMS`), so that every public name has a page and a new name gets one without
editing these files: the pages go to ``docs/api/`` (not committed).
"""

from __future__ import annotations

import importlib
import os
import pkgutil
import sys
from pathlib import Path

from sphinx.application import Sphinx
from sphinx.config import Config

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))  # the checkout's obsnl, also when it is not installed in editable mode

os.environ.setdefault("MPLBACKEND", "Agg")

import obsnl

project = "obsnl"
author = "the obsnl developers"
copyright = "the obsnl developers, MIT licence"
release = obsnl.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
templates_path = ["_templates"]
# observer_bank.md is read through bank.md (its last line, a transition, ends no document in docutils)
exclude_patterns = ["_build", "tutorials/GALLERY_HEADER.rst", "observer_bank.md", "**.ipynb_checkpoints"]

html_theme = "furo"
html_title = f"obsnl {release}"
html_static_path: list[str] = []

# --- the API reference -------------------------------------------------------------------------------------------
autosummary_generate = True  # set to the API pages by _write_api
autosummary_imported_members = True
autodoc_typehints = "none"  # the signature shows the hints; numpydoc's Parameters section the types in words
autodoc_default_options = {"members": False}
autodoc_member_order = "bysource"
numpydoc_show_class_members = False  # a class page lists no member table (the members are in its docstring)
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# --- the pages in Markdown (MyST) --------------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

# --- the tutorials: run at build time (sphinx-gallery) ----------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "tutorials",
    "gallery_dirs": "auto_tutorials",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",  # plot_1_..., plot_2_...: the reading order
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "show_memory": False,
    "matplotlib_animations": False,
    "reset_modules": ("matplotlib",),
    "image_scrapers": ("matplotlib",),
    "reference_url": {"obsnl": None},  # a name of obsnl in a tutorial's code links to its reference page
}

#: The reference's pages: (module, title, names documented there). ``obsnl`` is the flat API; each room lists its
#: own ``__all__`` (a name that the flat API exports too keeps its page there and is linked from the room).
ROOMS: list[tuple[str, str]] = [
    ("obsnl", "The flat API (``import obsnl``)"),
    ("obsnl.model", "Models and branches"),
    ("obsnl.algebra", "Exact arithmetic below the engines (no public names: its modules)"),
    ("obsnl.observability", "Observability: the analysis, its verdicts and the branch table"),
    ("obsnl.recombination", "Identifiable combinations and reparametrization"),
    ("obsnl.estimation", "The filter core: numeric model, UKF, DUKF, records"),
    ("obsnl.identification", "Identification from data"),
    ("obsnl.identification.validation", "Validation on a test record"),
    ("obsnl.design", "Sensors and experiment design"),
    ("obsnl.linear", "Linear observability, observers and the observer bank"),
    ("obsnl.report", "Renderings: tables, text, figures"),
    ("obsnl.report.identification", "Renderings of identification runs and Table 2"),
    ("obsnl.studies", "Studies: the seed paper, the cantilever link, buildings"),
    ("obsnl.errors", "Errors"),
    ("obsnl.executor", "Executors: local processes or a Dask cluster"),
    ("obsnl.batch", "Many models at once"),
    ("obsnl.commands", "Commands: one request, run and printed result per command"),
    ("obsnl.cli", "The command line"),
]


def _canonical(module: str, name: str) -> str:
    """The page that documents ``module.name``: the flat API's for a name ``obsnl`` exports as the same object."""
    same = module != "obsnl" and name in obsnl.__all__ and getattr(obsnl, name) is getattr(
        importlib.import_module(module), name)
    return f"obsnl.{name}" if same else f"{module}.{name}"


def _modules_of(room: str) -> list[str]:
    """The modules inside a room, private ones and those of a sub-room with its own page left out."""
    package = importlib.import_module(room)
    if room == "obsnl" or not hasattr(package, "__path__"):
        return []
    subrooms = [m for m, _ in ROOMS if m.startswith(room + ".")]
    return [info.name for info in pkgutil.walk_packages(package.__path__, f"{room}.")
            if not any(part.startswith("_") for part in info.name.split("."))
            and not any(info.name == s or info.name.startswith(s + ".") for s in subrooms)]


def _write(path: Path, text: str) -> None:
    """Write ``text`` unless the file holds it already (an unchanged page keeps its time: no re-read)."""
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


def _room_page(module: str, title: str) -> str:
    """The reST of one room's page: its charter, its public names, what each of its modules owns."""
    names = list(getattr(importlib.import_module(module), "__all__", ()))
    own = [n for n in names if _canonical(module, n) == f"{module}.{n}"]
    elsewhere = [n for n in names if n not in own]
    lines = [title, "=" * len(title), "", f".. automodule:: {module}", "   :no-members:", ""]
    if own:
        lines += [".. autosummary::", "   :toctree: generated", "   :nosignatures:", "", *[f"   {n}" for n in own], ""]
    if elsewhere:
        lines += ["Also in this room, documented with the flat API: "
                  + ", ".join(f":py:obj:`~obsnl.{n}`" for n in elsewhere) + ".", ""]
    modules = _modules_of(module)
    if modules:
        lines += ["Its modules", "-----------", "", "What each module of the room owns (its docstring).", "",
                  ".. autosummary::", "   :toctree: generated", "",
                  *[f"   {m[len(module) + 1:]}" for m in modules], ""]
    return "\n".join(lines)


def _write_api(app: Sphinx, config: Config) -> None:
    """Write ``docs/api/*.rst`` from the public names (each build, so that the pages follow the package)."""
    out = HERE / "api"
    out.mkdir(exist_ok=True)
    pages = [module.replace(".", "_") for module, _ in ROOMS]
    for page, (module, title) in zip(pages, ROOMS):
        _write(out / f"{page}.rst", _room_page(module, title))
    index = ["API reference", "=============", "",
             "Every public name of obsnl: the flat API that ``import obsnl`` offers, then each room (subpackage)",
             "with its charter, its own public names and what each of its modules owns.", "",
             ".. toctree::", "   :maxdepth: 1", "", *[f"   {p}" for p in pages], ""]
    _write(out / "index.rst", "\n".join(index))
    # the pages autosummary writes stubs for, named: an incremental build lists only the sources it knew before
    config.autosummary_generate = [f"api/{page}.rst" for page in pages]


def setup(app: Sphinx) -> None:
    app.connect("config-inited", _write_api)  # before the sources are listed and autosummary writes the stubs
