"""What a simulation found: photos registered, models, the surface rebuilt by class, and the bar a photo set must pass."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from coverplan.errors import InputFileError
from coverplan.files import json_text

# Reconstructable (docs/design.md): one model holding >= 98 % of the photos, >= 95 % of the
# surface within 0.2 m of a 3D point and >= 90 % in every class.
REGISTERED_MIN = 0.98


SURFACE_MIN = 95.0


CLASS_MIN = 90.0


@dataclass
class Simulation:
    """What SfM made of a route's photos (the worst draw, with every draw's summary).

    Parameters
    ----------
    photos : int
        Photos rendered.
    registered, registered_any : int
        Photos in the largest model, and in any model.
    models : int
        Models COLMAP returned.
    points : int
        3D points of the largest model.
    reprojection_error_px : float
        Its mean reprojection error in px.
    centre_error_m : dict
        Median and max camera-centre error (m) of the largest model after alignment.
    surface : dict
        The surface rebuilt at 0.1 and 0.2 m, overall and per class.
    photo_width_px : int
        Width of the rendered photos.
    seconds : dict
        Each stage's time.
    shot_registered : (k,) bool
        Per photo, in route order: in the largest model.
    sample_points : (m, 3) float
        The judging samples.
    sample_distance : (m,) float
        Distance from each to the nearest 3D point (m).
    model_points : (p, 3) float
        The largest model's points in the scene's frame.
    conditions, texture : str
        Conditions ("ideal", "field", "harsh") and texture family flown.
    flown_offset_m : dict
        Median and max distance between where photos were taken and where they were planned.
    draws : list of dict
        Every draw's summary, the worst included.
    worst_draw : int
        Index of the worst draw in ``draws``: the verdict.
    mapper : str
        COLMAP's mapper that made the model.
    """

    photos: int
    registered: int
    registered_any: int
    models: int
    points: int
    reprojection_error_px: float
    centre_error_m: dict
    surface: dict
    photo_width_px: int
    seconds: dict
    shot_registered: np.ndarray = field(repr=False)
    sample_points: np.ndarray = field(repr=False)
    sample_distance: np.ndarray = field(repr=False)
    model_points: np.ndarray = field(repr=False)
    conditions: str = "ideal"
    texture: str = "ideal"
    flown_offset_m: dict = field(default_factory=lambda: {"median": 0.0, "max": 0.0})
    draws: list = field(default_factory=list)
    worst_draw: int = 0
    mapper: str = "incremental"

    @property
    def least_class(self) -> tuple[str, float]:
        """The surface class with area that is least rebuilt at 0.2 m, and its %."""
        by = self.surface["by_radius"]["0.2"]["by_class_pct"]
        areas = self.surface["class_area_m2"]
        live = {c: v for c, v in by.items() if areas.get(c, 0) > 0}
        if not live:
            return "", float("nan")
        c = min(live, key=live.get)
        return c, float(live[c])

    @property
    def severity(self) -> tuple:
        """Sort key, smallest = worst: failed first, then fewest photos in the model, least surface."""
        return (self.reconstructable, self.registered / max(self.photos, 1), self.reconstructed_pct,
                self.least_class[1])

    def summary(self) -> dict:
        """One draw in a few numbers (for the draws table and reports).

        Returns
        -------
        dict
            Photos, registered, models, surface at 0.2 m.
        """
        by = self.surface["by_radius"]["0.2"]
        c, v = self.least_class
        return {"photos": self.photos, "registered": self.registered, "models": self.models,
                "surface_0.2_pct": by["pct"], "surface_0.1_pct": self.surface["by_radius"]["0.1"]["pct"],
                "by_class_pct": dict(by["by_class_pct"]), "least_class": c, "least_class_pct": v,
                "reconstructable": self.reconstructable, "flown_offset_m": self.flown_offset_m}

    @property
    def reconstructed_pct(self) -> float:
        """The target surface with a 3D point within 0.2 m, percent."""
        return self.surface["by_radius"]["0.2"]["pct"]

    @property
    def reconstructable(self) -> bool:
        """Whether the photo set passes: enough photos in one model and enough surface rebuilt."""
        by = self.surface["by_radius"]["0.2"]
        return (self.registered >= REGISTERED_MIN * self.photos and by["pct"] >= SURFACE_MIN
                and all(v >= CLASS_MIN for c, v in by["by_class_pct"].items()
                        if self.surface["class_area_m2"].get(c, 0) > 0))

    def to_dict(self) -> dict:
        return {"photos": self.photos, "registered": self.registered, "registered_any": self.registered_any,
                "models": self.models, "points": self.points,
                "reprojection_error_px": self.reprojection_error_px, "centre_error_m": self.centre_error_m,
                "surface": self.surface, "photo_width_px": self.photo_width_px, "seconds": self.seconds,
                "reconstructable": self.reconstructable, "conditions": self.conditions,
                "texture": self.texture, "flown_offset_m": self.flown_offset_m, "draws": self.draws,
                "worst_draw": self.worst_draw, "mapper": self.mapper,
                "shot_registered": self.shot_registered.tolist()}

    def table(self) -> str:
        rows = self.rows()
        w = max(len(r[0]) for r in rows)
        text = "\n".join(f"{k:<{w}}  {v}" for k, v in rows)
        return text + ("\n\n" + self.draws_table() if len(self.draws) > 1 else "")

    def rows(self) -> list[tuple[str, str]]:
        """The verdict as (label, value) rows: the conditions, then the worst draw's figures."""
        by02, by01 = self.surface["by_radius"]["0.2"], self.surface["by_radius"]["0.1"]
        rows = [("photos", f"{self.photos}" + (f" ({self.mapper} mapping)" if self.mapper != "incremental" else "")),
                ("registered (largest model)", f"{self.registered} ({100.0 * self.registered / max(self.photos, 1):.1f} %)"),
                ("registered in any model", f"{self.registered_any}"),
                ("models", f"{self.models}"),
                ("3D points", f"{self.points:,}"),
                ("reprojection error", f"{self.reprojection_error_px:.2f} px"),
                ("camera centre error", f"median {self.centre_error_m['median']:.3f} m, max {self.centre_error_m['max']:.3f} m"),
                ("surface reconstructed @0.1 m", f"{by01['pct']:.1f} %"),
                ("surface reconstructed @0.2 m", f"{by02['pct']:.1f} %")]
        rows += [(f"  {c}", f"{v:.1f} % of {self.surface['class_area_m2'][c]:.0f} m2")
                 for c, v in by02["by_class_pct"].items()]
        if not np.isfinite(self.centre_error_m["median"]):  # no true centres to compare with (check)
            rows = [r for r in rows if r[0] != "camera centre error"]
        rows.append(("reconstructable", "yes" if self.reconstructable else "no (it needs >= 98 % of the photos "
                                                                          "registered, >= 95 % of the surface and "
                                                                          ">= 90 % of every class)"))
        head = [("conditions", f"{self.conditions}" + (f", {self.texture} textures" if self.texture != "ideal" else "")
                 + (f"; photos taken a median {self.flown_offset_m['median']:.2f} m (max "
                    f"{self.flown_offset_m['max']:.2f} m) from the plan" if self.conditions != "ideal" else ""))]
        if len(self.draws) > 1:
            head.append(("draws", f"{len(self.draws)}; the verdict is the worst (draw {self.worst_draw + 1})"))
        return head + rows

    def draws_table(self) -> str:
        """Worst and median of the draws, then each draw.

        Returns
        -------
        str
            A terminal table.
        """
        def row(label, d):
            return (label, f"{d['registered']}/{d['photos']}", f"{d['models']}", f"{d['surface_0.2_pct']:.1f} %",
                    f"{d['least_class']} {d['least_class_pct']:.1f} %".strip(), "yes" if d["reconstructable"] else "no")
        med = {"photos": self.photos,
               "registered": int(np.median([d["registered"] for d in self.draws])),
               "models": int(np.median([d["models"] for d in self.draws])),
               "surface_0.2_pct": float(np.median([d["surface_0.2_pct"] for d in self.draws])),
               "least_class": "", "least_class_pct": float(np.median([d["least_class_pct"] for d in self.draws])),
               "reconstructable": sum(d["reconstructable"] for d in self.draws) * 2 > len(self.draws)}
        rows = [("draw", "registered", "models", "surface @0.2 m", "least class", "reconstructable"),
                row("worst", self.draws[self.worst_draw]), row("median", med)]
        rows += [row(f"seed {d['seed']}", d) for d in self.draws]
        widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
        return "\n".join("  ".join(c.ljust(wd) for c, wd in zip(r, widths)).rstrip() for r in rows)

    def reconstructed_at(self, points, radius: float = 0.2) -> np.ndarray:
        """Per point, whether a 3D point of the largest model lies within ``radius``.

        Parameters
        ----------
        points : (n, 3) float
            Local coordinates.
        radius : float
            Metres.

        Returns
        -------
        (n,) bool
            Points near the model.
        """
        if len(self.model_points) == 0:
            return np.zeros(len(points), dtype=bool)
        from scipy.spatial import cKDTree
        dist, _ = cKDTree(self.model_points).query(np.asarray(points, dtype=float), distance_upper_bound=radius)
        return dist <= radius

    def save(self, path) -> Path:
        """Write the summary as JSON and the aligned 3D points beside it (``*.points.ply``).

        Parameters
        ----------
        path : str or Path
            The JSON file.

        Returns
        -------
        Path
            ``path``.
        """
        import trimesh

        path = Path(path)
        path.write_text(json_text(self.to_dict()))
        if len(self.model_points):
            trimesh.PointCloud(self.model_points).export(_points_path(path))
        return path

    @classmethod
    def load(cls, path) -> "Simulation":
        """A saved simulation (for reports): the summary and the aligned 3D points.

        Parameters
        ----------
        path : str or Path
            The JSON file.

        Returns
        -------
        Simulation
            The simulation.
        """
        import trimesh

        path = Path(path)
        try:
            d = json.loads(path.read_text())
            nan = float("nan")  # written as null: no value
            d["centre_error_m"] = {k: nan if v is None else v for k, v in d["centre_error_m"].items()}
            d["reprojection_error_px"] = nan if d["reprojection_error_px"] is None else d["reprojection_error_px"]
            points_file = _points_path(path)
            pts = np.asarray(trimesh.load(points_file).vertices) if points_file.exists() else np.zeros((0, 3))
            return cls(d["photos"], d["registered"], d["registered_any"], d["models"], d["points"],
                       d["reprojection_error_px"], d["centre_error_m"], d["surface"], d["photo_width_px"],
                       d["seconds"], np.array(d["shot_registered"], dtype=bool), np.zeros((0, 3)), np.zeros(0), pts,
                       conditions=d.get("conditions", "ideal"), texture=d.get("texture", "ideal"),
                       flown_offset_m=d.get("flown_offset_m", {"median": 0.0, "max": 0.0}),
                       draws=d.get("draws", []), worst_draw=d.get("worst_draw", 0),
                       mapper=d.get("mapper", "incremental"))
        except FileNotFoundError:
            raise InputFileError(str(path), "no such file") from None
        except (ValueError, KeyError, TypeError) as exc:
            raise InputFileError(str(path), f"is not a coverplan simulation ({exc})") from None


def _points_path(path: Path) -> Path:
    return path.with_name(path.stem + ".points.ply")
