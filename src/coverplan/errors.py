"""Errors a user can act on. The CLI prints their message on one line and exits 2."""

from __future__ import annotations


class CoverplanError(Exception):
    """Base class: a problem with the user's input or settings, not a bug."""


class InputFileError(CoverplanError):
    """A file is missing, unreadable, of an unknown format, or holds no usable data.

    Parameters
    ----------
    path : path
        The file.
    problem : str
        What is wrong with it, in one line.
    """

    def __init__(self, path, problem: str):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


class RouteFormatError(InputFileError):
    """A route file that does not follow the coverplan-route format.

    Parameters
    ----------
    path : path
        The file.
    problem : str
        What is wrong with it, in one line.
    """


class ParameterError(CoverplanError):
    """A parameter value that cannot work (non-positive size, unknown preset, ...)."""


class PlanningError(CoverplanError):
    """Settings that make a plan impossible (start inside a mesh, d_opt <= security, ...)."""


class SfmError(CoverplanError):
    """COLMAP failed in one of its stages; what it had written is kept for a look or a rerun."""
