"""Sphinx configuration of coverplan's API reference (built with warnings as errors by the test suite).

``index.rst`` documents the facade; the reference of every module is written at build time
(``reference/``, one page per subpackage, every module's public names with their docstrings),
so a module added to the package is in the reference, and validated, without editing a page.
"""

import importlib
import pkgutil
import re
from pathlib import Path

import coverplan

project = "coverplan"
extensions = ["sphinx.ext.autodoc", "numpydoc"]
exclude_patterns = ["_build"]
html_theme = "alabaster"
autodoc_typehints = "none"  # the numpydoc sections carry the types and shapes
autodoc_default_options = {"members": True, "undoc-members": True, "member-order": "bysource"}  # of classes
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
# Every public function, class and method documents its parameters, what it returns and a
# one-line summary; a missing docstring or an undocumented parameter is a warning, so the
# build fails.
numpydoc_validation_checks = {"GL08", "PR01", "PR02", "PR10", "RT01", "SS01", "SS03"}
numpydoc_validation_exclude = {r"\.__init__$", r"\._", r"\.(to_dict|from_dict|table|rows)$"}
suppress_warnings = []

REFERENCE = Path(__file__).parent / "reference"


def public_modules():
    """Every module of the package but ``__main__`` and private ones, by subpackage.

    Returns
    -------
    dict of str to list of str
        Subpackage (or ``coverplan`` for the top-level modules) to its modules' names.
    """
    groups = {}
    for info in pkgutil.walk_packages(coverplan.__path__, "coverplan."):
        parts = info.name.split(".")
        if parts[-1].startswith("_"):
            continue
        group = "coverplan" if len(parts) == 2 and not info.ispkg else ".".join(parts[:2])
        groups.setdefault(group, []).append(info.name)
    return groups


def own_names(module_name):
    """The public functions and classes a module defines (not those it imports).

    Parameters
    ----------
    module_name : str
        A module's dotted name.

    Returns
    -------
    list of str
        In the order the module defines them.
    """
    module = importlib.import_module(module_name)
    return [name for name, obj in vars(module).items()
            if not name.startswith("_") and callable(obj) and getattr(obj, "__module__", None) == module_name]


def write_reference(app=None):
    """Write one page per subpackage into ``reference/`` and its table of contents.

    Parameters
    ----------
    app : sphinx.application.Sphinx, optional
        The application, when run as its ``builder-inited`` hook (before the sources are read).
    """
    REFERENCE.mkdir(exist_ok=True)
    pages = []
    for group, modules in sorted(public_modules().items()):
        title = "top-level modules" if group == "coverplan" else group
        lines = [title, "=" * len(title), ""]
        for module in sorted(modules):
            names = own_names(module)
            lines += [module, "-" * len(module), "", f".. automodule:: {module}"]
            lines += [f"   :members: {', '.join(names)}", ""] if names else ["   :no-members:", ""]
        page = group.replace(".", "_")
        (REFERENCE / f"{page}.rst").write_text("\n".join(lines), encoding="utf-8")
        pages.append(page)
    toc = ["Module reference", "================", "", ".. toctree::", "   :maxdepth: 1", ""]
    toc += [f"   {page}" for page in pages]
    (REFERENCE / "index.rst").write_text("\n".join(toc) + "\n", encoding="utf-8")


def imported_names():
    """Regular expressions of every name a module imports rather than defines.

    Returns
    -------
    set of str
        ``^module\\.name$`` for each: autodoc looks at them while it filters a module's
        members, and their docstrings are their own package's business.
    """
    out = set()
    for modules in public_modules().values():
        for module_name in modules:
            own = set(own_names(module_name))
            for name in vars(importlib.import_module(module_name)):
                if not name.startswith("_") and name not in own:
                    out.add("^" + re.escape(f"{module_name}.{name}") + "$")
    return out


def skip_foreign(app, what, name, obj, skip, options):
    """Skip a module's members defined outside coverplan (``Path``, ``dataclass``, ``cKDTree`` ...)."""
    module = getattr(obj, "__module__", None)
    if what == "module" and module is not None and not str(module).startswith("coverplan"):
        return True
    return None


def setup(app):
    app.connect("builder-inited", write_reference)
    app.connect("autodoc-skip-member", skip_foreign)


numpydoc_validation_exclude |= imported_names()
