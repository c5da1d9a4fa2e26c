"""The scene a bag was recorded from, as its metadata names it.

``tensegrity record --custom-data scene=NAME`` (and ``ros2 bag record --custom-data``) store
it in the bag's ``custom_data``; ``tensegrity up --record`` and the demo store the scene they
ran. A bag is outside input: the name it gives must be a shipped scene, never a path.
"""

from __future__ import annotations

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.reader import BagReader


def unread_custom_data(reader: BagReader, path: object) -> str:
    """One line saying that ``reader``'s bag's ``custom_data`` cannot be read and what that
    loses (the scene it was recorded from); "" when it can be read or there is none."""
    try:
        _ = reader.custom_data
    except BagError as err:
        return (f"the custom_data of bag {path} cannot be read, so the scene it was recorded from is "
                f"unknown (name it with --scene NAME where a command needs it): {err}")
    return ""


def recorded_scene(reader: BagReader, path: object) -> str | None:
    """The shipped scene ``reader``'s bag names in its metadata, None when it names none;
    BagError (one line) when it names something that is not a shipped scene, or when its
    ``custom_data`` cannot be read (:func:`unread_custom_data`)."""
    unread = unread_custom_data(reader, path)
    if unread:
        raise BagError(unread)
    # imported here, not at the top: the simulator package takes ~1 s of CPU to import, which
    # every `tensegrity play` (which reads only the custom_data) would otherwise pay
    from tensegrity_core.sim import scene_names

    scene = (reader.custom_data or {}).get("scene")
    if scene and scene not in scene_names():
        raise BagError(f"bag {path} names scene {scene!r} in its metadata, which is not a shipped scene "
                       "(`tensegrity scenes`): name the scene with --scene NAME or FILE")
    return scene or None
