"""Photos already taken (a flight flown, or a mission already trusted): their views count
toward every rule of a new plan, which then takes only the shots they do not give.

They enter the planner as candidates the selection starts from and never drops
(``Candidates.source`` EXISTING); the new flight flies only the others. They are not held to
the security distance or the gimbal range: they are taken, not flown.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coverplan.errors import ParameterError
from coverplan.shots.candidates import Candidates

EXISTING = 9  # Candidates.source of a photo already taken


@dataclass(frozen=True, eq=False)
class ExistingShots:
    """Poses of photos already taken, in the scene's frame.

    Parameters
    ----------
    positions : (k, 3) float
        Camera centres.
    heading_deg, pitch_deg : (k,) float
        Orientations.
    source : str
        What they came from (a photo folder, a mission file), for the summary.
    """

    positions: np.ndarray
    heading_deg: np.ndarray
    pitch_deg: np.ndarray
    source: str = "existing photos"

    def __post_init__(self):
        p = np.asarray(self.positions, dtype=float).reshape(-1, 3)
        h = np.asarray(self.heading_deg, dtype=float).reshape(-1)
        t = np.asarray(self.pitch_deg, dtype=float).reshape(-1)
        if not (len(p) == len(h) == len(t)):
            raise ParameterError("existing photos need one position, heading and pitch each")
        if len(p) == 0:
            raise ParameterError(f"{self.source} hold no photos")
        if not (np.isfinite(p).all() and np.isfinite(h).all() and np.isfinite(t).all()):
            raise ParameterError(f"{self.source}: every photo needs a finite position, heading and pitch")
        object.__setattr__(self, "positions", p)
        object.__setattr__(self, "heading_deg", h)
        object.__setattr__(self, "pitch_deg", t)

    def __len__(self) -> int:
        return len(self.positions)

    @classmethod
    def of_route(cls, route, source: str | None = None) -> "ExistingShots":
        """The photos of a route (or of a mission read as one), where they are taken.

        Parameters
        ----------
        route : Route
            The route or mission.
        source : str, optional
            What it is; the route's own description when None.

        Returns
        -------
        ExistingShots
            Its photos.
        """
        rows = route.shots
        return cls(route.flown_positions()[rows], route.heading_deg[rows], route.pitch_deg[rows],
                   source or str(route.extra.get("source", "existing route")))

    def candidates(self) -> Candidates:
        """The photos as candidates of their own source, to be kept by every selection.

        Returns
        -------
        Candidates
            One row per photo.
        """
        return Candidates(self.positions.copy(), self.heading_deg.copy(), self.pitch_deg.copy(),
                          np.full(len(self), EXISTING, dtype=np.int8))
