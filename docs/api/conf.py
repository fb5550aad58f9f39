"""Sphinx configuration of coverplan's API reference (built with warnings as errors by the test suite)."""

project = "coverplan"
extensions = ["sphinx.ext.autodoc", "numpydoc"]
exclude_patterns = ["_build"]
html_theme = "alabaster"
autodoc_typehints = "none"  # the numpydoc sections carry the types and shapes
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
# Every public entry point documents its parameters, what it returns and a one-line summary;
# a missing docstring or an undocumented parameter is a warning, so the build fails.
numpydoc_validation_checks = {"GL08", "PR01", "PR02", "PR10", "RT01", "SS01", "SS03"}
numpydoc_validation_exclude = {r"\.__init__$", r"\._", r"\.(to_dict|from_dict|table|rows)$"}
suppress_warnings = []
