"""Keep-out and keep-in zones: vertical prisms over polygons, in the scene's local frame.

A keep-out zone is airspace the flight may not enter (the street, the neighbour's garden, the
railway); a keep-in zone is airspace it may not leave (the property agreed with the owner).
Each is a polygon (holes allowed) between a floor and a ceiling, absolute heights in the local
frame (-inf / inf: from the ground / without a top). The prism is closed: its boundary belongs
to it, so a keep-out zone's edge is already inside it, and a keep-in zone's edge is still in.

Segments are tested exactly: the part of a segment within a prism's heights is a straight
piece, which enters the prism if its plan view meets the polygon (shapely's ``intersects``),
and stays in a keep-in zone if the polygon covers it. Several keep-in zones are one region,
their union; a segment that crosses from one to another of different heights is only allowed
where the union of the zones whose heights hold it covers it (so never wrongly allowed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

KEEP_OUT, KEEP_IN = "keep-out", "keep-in"


@dataclass(frozen=True, eq=False)
class Zone:
    """One prism: ``polygon`` (shapely Polygon or MultiPolygon, local x, y in m) from
    ``floor`` to ``ceiling`` (local z, m).

    Parameters
    ----------
    name : str
        The zone's name.
    kind : {"keep_out", "keep_in"}
        Whether the flight must stay out or in.
    polygon : shapely.Polygon or shapely.MultiPolygon
        Local x, y, metres.
    floor, ceiling : float
        Local z, metres.
    """

    name: str
    kind: str  # KEEP_OUT or KEEP_IN
    polygon: object
    floor: float = -np.inf
    ceiling: float = np.inf

    def __post_init__(self):
        if self.kind not in (KEEP_OUT, KEEP_IN):
            raise ValueError(f"zone kind must be {KEEP_OUT!r} or {KEEP_IN!r}, got {self.kind!r}")
        shapely.prepare(self.polygon)

    @property
    def label(self) -> str:
        """How messages name the zone."""
        return f"{self.kind} zone {self.name}"

    def to_dict(self) -> dict:
        """The zone as the route file records it (local frame, null for no floor/ceiling)."""
        polys = getattr(self.polygon, "geoms", [self.polygon])
        return {"name": self.name, "kind": self.kind,
                "polygons": [[np.asarray(p.exterior.coords)[:, :2].tolist()]
                             + [np.asarray(r.coords)[:, :2].tolist() for r in p.interiors] for p in polys],
                "floor_m": None if not np.isfinite(self.floor) else float(self.floor),
                "ceiling_m": None if not np.isfinite(self.ceiling) else float(self.ceiling)}

    @classmethod
    def from_dict(cls, d: dict) -> Zone:
        polys = [shapely.Polygon(rings[0], rings[1:]) for rings in d["polygons"]]
        polygon = polys[0] if len(polys) == 1 else shapely.MultiPolygon(polys)
        floor, ceiling = d.get("floor_m"), d.get("ceiling_m")
        return cls(str(d["name"]), str(d["kind"]), polygon, -np.inf if floor is None else float(floor),
                   np.inf if ceiling is None else float(ceiling))


@dataclass(frozen=True)
class Zones:
    """The zones a flight must respect.

    Parameters
    ----------
    zones : tuple of Zone
        Every zone.
    """

    zones: tuple[Zone, ...] = ()

    def __bool__(self) -> bool:
        return len(self.zones) > 0

    def __len__(self) -> int:
        return len(self.zones)

    @property
    def keep_out(self) -> list[Zone]:
        """The keep-out zones."""
        return [z for z in self.zones if z.kind == KEEP_OUT]

    @property
    def keep_in(self) -> list[Zone]:
        """The keep-in zones."""
        return [z for z in self.zones if z.kind == KEEP_IN]

    def to_list(self) -> list[dict]:
        """The zones as the route file's ``params.zones``.

        Returns
        -------
        list of dict
            One dict per zone.
        """
        return [z.to_dict() for z in self.zones]

    @classmethod
    def from_list(cls, items) -> Zones:
        """The zones of a route file's ``params.zones``.

        Parameters
        ----------
        items : list of dict or None
            As ``to_list`` writes them.

        Returns
        -------
        Zones
            The zones.
        """
        return cls(tuple(Zone.from_dict(d) for d in (items or ())))

    def points_allowed(self, points) -> np.ndarray:
        """Whether each point is outside every keep-out zone and inside the keep-in region.

        Parameters
        ----------
        points : (n, 3) float

        Returns
        -------
        (n,) bool
        """
        return self.point_breaches(points) < 0

    def point_breaches(self, points) -> np.ndarray:
        """Per point: the index (into ``zones``) of a zone it breaches, or -1.

        Parameters
        ----------
        points : (n, 3) float

        Returns
        -------
        (n,) int
        """
        return self.segment_breaches(points, points)  # a point is a segment of no length

    def segments_allowed(self, starts, ends) -> np.ndarray:
        """Whether each segment stays outside every keep-out zone and inside the keep-in region.

        Parameters
        ----------
        starts, ends : (n, 3) float

        Returns
        -------
        (n,) bool
        """
        return self.segment_breaches(starts, ends) < 0

    def segment_breaches(self, starts, ends) -> np.ndarray:
        """Per segment: the index (into ``zones``) of a zone it breaches, or -1 (exact).

        Parameters
        ----------
        starts, ends : (n, 3) float

        Returns
        -------
        (n,) int
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        out = np.full(len(starts), -1, dtype=np.int64)
        if not self.zones or len(starts) == 0:
            return out
        for k, z in enumerate(self.zones):
            if z.kind != KEEP_OUT:
                continue
            live = np.flatnonzero(out < 0)
            a, b, ok = _clip_to_heights(starts[live], ends[live], z.floor, z.ceiling)
            hit = np.zeros(len(live), dtype=bool)
            if ok.any():
                hit[ok] = _bbox_near(a[ok], b[ok], z.polygon)
                near = np.flatnonzero(hit)
                if len(near):
                    hit[near] = shapely.intersects(z.polygon, _lines(a[near], b[near]))
            out[live[hit]] = k
        keep_in = [k for k, z in enumerate(self.zones) if z.kind == KEEP_IN]
        if keep_in:
            live = np.flatnonzero(out < 0)
            lo = np.minimum(starts[live, 2], ends[live, 2])
            hi = np.maximum(starts[live, 2], ends[live, 2])
            holds = np.array([(lo >= self.zones[k].floor) & (hi <= self.zones[k].ceiling) for k in keep_in]).T
            inside = np.zeros(len(live), dtype=bool)
            for mask in np.unique(holds, axis=0):
                if not mask.any():
                    continue
                group = np.flatnonzero((holds == mask).all(axis=1))
                region = shapely.union_all([self.zones[k].polygon for k, m in zip(keep_in, mask) if m])
                shapely.prepare(region)
                inside[group] = shapely.covers(region, _lines(starts[live[group]], ends[live[group]]))
            out[live[~inside]] = keep_in[0]
        return out

    def grown(self, margin: float) -> Zones:
        """The zones with a margin against the drone's position error: keep-out zones grown by
        ``margin`` (m) sideways, down and up, keep-in zones shrunk by it. A keep-in zone
        narrower than twice the margin comes out empty (nowhere to fly).

        Parameters
        ----------
        margin : float
            Metres.

        Returns
        -------
        Zones
            New zones.
        """
        if margin <= 0:
            return self
        out = []
        for z in self.zones:
            sign = 1.0 if z.kind == KEEP_OUT else -1.0
            polygon = z.polygon.buffer(sign * margin)
            out.append(Zone(z.name, z.kind, polygon, z.floor - sign * margin, z.ceiling + sign * margin))
        return Zones(tuple(out))

    def plan_distance(self, starts, ends) -> np.ndarray:
        """Per segment: its least plan-view distance to a keep-out zone's polygon or to the
        keep-in region's boundary (inf without zones), whatever the zones' heights.

        Parameters
        ----------
        starts, ends : (n, 3) float

        Returns
        -------
        (n,) float
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        out = np.full(len(starts), np.inf)
        if not self.zones or len(starts) == 0:
            return out
        lines = _lines(starts, ends)
        for z in self.zones:
            target = z.polygon if z.kind == KEEP_OUT else z.polygon.boundary
            out = np.minimum(out, shapely.distance(target, lines))
        return out

    def describe(self, index: int) -> str:
        """The label of zone ``index``.

        Parameters
        ----------
        index : int
            The zone's index.

        Returns
        -------
        str
            Its label.
        """
        return self.zones[int(index)].label

    def closing_off(self, outline, low: float, high: float) -> list[str]:
        """What leaves no airspace round a target: the names of keep-out zones that together
        cover ``outline`` (shapely geometry: the target's plan grown by the reach of its
        viewpoints) from ``low`` to ``high``, or of a keep-in region that misses it.

        Parameters
        ----------
        outline : shapely geometry
            The target's plan grown by the reach of its viewpoints.
        low, high : float
            The heights photographed from, metres.

        Returns
        -------
        list of str
            Zone labels; empty when some airspace round the target is open.
        """
        whole = [z for z in self.keep_out if z.floor <= low and z.ceiling >= high]
        if whole and shapely.union_all([z.polygon for z in whole]).covers(outline):
            return [z.label for z in whole if z.polygon.intersects(outline)]
        keep_in = self.keep_in
        if keep_in and not any(z.polygon.intersects(outline) and z.floor <= high and z.ceiling >= low
                               for z in keep_in):
            return [z.label for z in keep_in]
        return []


def _clip_to_heights(starts, ends, floor: float, ceiling: float):
    """The piece of each segment within [floor, ceiling]: its ends and whether there is one."""
    dz = ends[:, 2] - starts[:, 2]
    flat = np.abs(dz) < 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        t_f = (floor - starts[:, 2]) / np.where(flat, 1.0, dz)
        t_c = (ceiling - starts[:, 2]) / np.where(flat, 1.0, dz)
    t0 = np.where(flat, 0.0, np.maximum(np.minimum(t_f, t_c), 0.0))
    t1 = np.where(flat, 1.0, np.minimum(np.maximum(t_f, t_c), 1.0))
    # A segment too nearly level to divide by dz counts whole where any of it is within the heights.
    lo, hi = np.minimum(starts[:, 2], ends[:, 2]), np.maximum(starts[:, 2], ends[:, 2])
    ok = np.where(flat, (hi >= floor) & (lo <= ceiling), t0 <= t1)
    d = ends - starts
    return starts + t0[:, None] * d, starts + np.clip(t1, t0, 1.0)[:, None] * d, ok


def _bbox_near(a: np.ndarray, b: np.ndarray, polygon) -> np.ndarray:
    """Whether each segment's plan-view box meets the polygon's (a cheap first cut)."""
    x0, y0, x1, y1 = polygon.bounds
    return ((np.maximum(a[:, 0], b[:, 0]) >= x0) & (np.minimum(a[:, 0], b[:, 0]) <= x1)
            & (np.maximum(a[:, 1], b[:, 1]) >= y0) & (np.minimum(a[:, 1], b[:, 1]) <= y1))


def _lines(a: np.ndarray, b: np.ndarray):
    """Plan-view geometries of segments: a line, or a point where the ends coincide."""
    coords = np.stack([a[:, :2], b[:, :2]], axis=1)
    same = np.all(np.abs(coords[:, 0] - coords[:, 1]) < 1e-12, axis=1)
    out = np.empty(len(a), dtype=object)
    if (~same).any():
        out[~same] = shapely.linestrings(coords[~same])
    if same.any():
        out[same] = shapely.points(coords[same, 0])
    return out
