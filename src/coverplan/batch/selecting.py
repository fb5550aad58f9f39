"""Which buildings of a city model a batch plans, and the folder each gets."""

from __future__ import annotations

import re

from coverplan.errors import InputFileError, ParameterError
from coverplan.io.city import CityModel, CityObject


def parse_where(items: list[str] | None) -> list[tuple[str, str]]:
    """ATTR=VALUE pairs (a ParameterError for anything else).

    Parameters
    ----------
    items : list of str or None
        ``ATTR=VALUE`` strings as given on the command line.

    Returns
    -------
    list of (str, str)
        The attribute and value of each item.

    Raises
    ------
    ParameterError
        An item without ``=`` or with an empty attribute.
    """
    pairs = []
    for item in items or []:
        attr, sep, value = item.partition("=")
        if not sep or not attr.strip():
            raise ParameterError(f"--where takes ATTR=VALUE, got {item!r}")
        pairs.append((attr.strip(), value.strip()))
    return pairs


def _matches(value, wanted: str) -> bool:
    if isinstance(value, list):
        return any(_matches(v, wanted) for v in value)
    if str(value) == wanted:
        return True
    try:
        return float(value) == float(wanted)
    except (TypeError, ValueError):
        return False


def select_buildings(model: CityModel, ids: list[str] | None = None, everything: bool = False,
                     bbox: list[float] | None = None, where: list[tuple[str, str]] | None = None) -> list[CityObject]:
    """The buildings a batch plans: by id, all, those centred in ``bbox`` (file coordinates,
    xmin ymin xmax ymax) and/or whose attributes equal every ``where`` value.

    Parameters
    ----------
    model : CityModel
        The city model read.
    ids : list of str, optional
        Building ids to plan.
    everything : bool
        Plan every building.
    bbox : list of float, optional
        ``xmin ymin xmax ymax`` in the file's coordinates.
    where : list of (str, str), optional
        Attribute values every chosen building has.

    Returns
    -------
    list of CityObject
        The chosen buildings, in the file's order.
    """
    buildings = model.buildings
    if not buildings:
        raise InputFileError(model.path, "holds no building with 3D geometry (LoD 1 or higher)")
    if ids:
        chosen, seen = [], set()
        for building in ids:
            obj = model.find(building)
            if obj.id not in seen:
                seen.add(obj.id)
                chosen.append(obj)
        return chosen
    if not (everything or bbox or where):
        raise ParameterError("choose the buildings: --buildings ID ..., --all, --bbox XMIN YMIN XMAX YMAX "
                             "or --where ATTR=VALUE")
    chosen = buildings
    if bbox is not None:
        xmin, ymin, xmax, ymax = (float(v) for v in bbox)
        if not (xmin < xmax and ymin < ymax):
            raise ParameterError(f"--bbox needs XMIN < XMAX and YMIN < YMAX, got {' '.join(f'{v:g}' for v in bbox)}")
        centre = {id(o): (box[:2] + box[2:]) / 2 for o, box in zip(model.with_geometry, model.xy_bounds(None))}
        chosen = [o for o in chosen if xmin <= centre[id(o)][0] <= xmax and ymin <= centre[id(o)][1] <= ymax]
    for attr, value in where or []:
        chosen = [o for o in chosen if attr in o.attributes and _matches(o.attributes[attr], value)]
    if not chosen:
        what = " and ".join(filter(None, [bbox is not None and "--bbox", where and "--where"]))
        known = sorted({k for o in buildings for k in o.attributes})
        raise ParameterError(f"no building of {model.path.name} matches {what}"
                             + (f" (attributes: {', '.join(known[:12])})" if where else ""))
    return chosen


def folder_names(objects: list[CityObject]) -> list[str]:
    """A file-system-safe, unique folder name per building id.

    Parameters
    ----------
    objects : list of CityObject
        The chosen buildings.

    Returns
    -------
    list of str
        One folder name per building, in the same order.
    """
    names, used = [], set()
    for obj in objects:
        base = re.sub(r"[^A-Za-z0-9._-]+", "_", obj.id).strip("._") or "building"
        name, k = base[:120], 2
        while name.lower() in used:
            name, k = f"{base[:116]}-{k}", k + 1
        used.add(name.lower())
        names.append(name)
    return names
