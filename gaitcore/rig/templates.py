"""The skeleton templates that ship with Gait Studio (``resources/skeletons/*.json``)."""

from __future__ import annotations

from importlib.resources import files

from gaitcore.errors import GaitInputError
from gaitcore.rig.skeleton import Skeleton


def load_template(name: str) -> Skeleton:
    """Load a built-in skeleton template from ``resources/skeletons/<name>.json``.

    The templates install inside the package (``gaitcore.resources``) and are read through
    :mod:`importlib.resources`, so an installed wheel finds them as a checkout does.

    Raises
    ------
    GaitInputError
        No template of that name; the message lists the available ones.
    """
    folder = files("gaitcore.resources") / "skeletons"
    path = folder / f"{name}.json"
    if not path.is_file():
        have = sorted(p.name.removesuffix(".json") for p in folder.iterdir())
        raise GaitInputError(f"no skeleton template {name!r}; available: {', '.join(have)}")
    return Skeleton.from_json(path)
