"""Where a UFF record's sensor sits and what the file calls it, kept from import to export.

``rig import uff`` keeps on each channel of a time record the record's response node, direction
code, entity name and ID line 1 (:func:`record_place`: the recording channel attributes
``node``, ``direction``, ``entity`` and ``description``); ``rig export uff`` writes them back
(:func:`channel_place`). Channels without them are numbered as the module docstring of
:mod:`rigtools.interop.uff` says: the rig's channels by their name in +Y, a foreign
recording's other channels from node 101 in channel order with direction 0 (none: the file
they came from gave none, and +Y, the blades' impact direction, would be made up).

Records of one name (two records of one DOF, as records 1 and 4 of the MPSTD file at node 1
+Z) are told apart by the first ID line that differs among them (:func:`told_apart`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rigtools.recording.schema import DIRECTION_MAX, NODE_MAX

#: UFF's words for "no text" in ID lines and names (pyuff reads ``NONE`` where a writer left it)
NONE_TEXT = ("", "none", "unknown")
ID_LINES = ("id1", "id2", "id3", "id4", "id5")
DIRECTION_Y = 2
FIXED_NODES = {"force": 1, "drive": 100}
FIRST_OTHER_NODE = 101


SHROUD_NODES = {"active_shroud": 2, "passive_shroud": 3}


def is_rig_channel(name: str) -> bool:
    """True for a channel the rig's numbering places by its name (force, drive, the shrouds)."""
    return name in FIXED_NODES or name.startswith(tuple(SHROUD_NODES))


def node_of(channel: str, order: int) -> int:
    """The UFF node number of a channel in the rig's numbering (:mod:`rigtools.interop.uff`);
    ``order`` is its position among the point's channels (101 + order for any other)."""
    if channel in FIXED_NODES:
        return FIXED_NODES[channel]
    for prefix, node in SHROUD_NODES.items():
        if channel.startswith(prefix):
            return node
    return FIRST_OTHER_NODE + order


def text_of(s: dict, key: str) -> str:
    """A record's text field, stripped; ``""`` for UFF's ``NONE``."""
    text = str(s.get(key, "")).strip()
    return "" if text.lower() in NONE_TEXT else text


def record_place(s: dict) -> dict[str, Any]:
    """What a channel keeps of a record's response: ``{"node", "direction", "entity",
    "description"}`` (:class:`rigtools.recording.ChannelSpec` fields; a field the record does not
    give, or gives out of range, is None)."""
    node, direction = int(s.get("rsp_node", 0)), int(s.get("rsp_dir", 0))
    return {
        "node": node if 0 <= node <= NODE_MAX else None,
        "direction": direction if abs(direction) <= DIRECTION_MAX else None,
        "entity": text_of(s, "rsp_ent_name") or None,
        "description": text_of(s, "id1") or None,
    }


@dataclass(frozen=True)
class Place:
    """Where an exported record says its sensor is.

    Attributes
    ----------
    entity, node, direction
        UFF entity name, node number and direction code of the response.
    description
        ID line 1 as imported (``""``: none; the export then describes the record itself).
    kept
        True when the recording holds them (an import's), False when numbered here.
    """

    entity: str
    node: int
    direction: int
    description: str
    kept: bool


def channel_place(name: str, order: int, channel: Any, *, foreign: bool) -> Place:
    """The place ``rig export uff`` writes for channel ``name`` (the ``order``-th of its point).

    The recording's ``node``/``direction``/``entity``/``description`` where it holds them;
    else the rig's numbering (:func:`node_of`) in +Y, except that in a ``foreign`` recording (an
    import) a channel the rig's numbering does not name gets direction 0 (none)."""
    node = getattr(channel, "node", None)
    if node is not None:
        direction = getattr(channel, "direction", None)
        return Place(
            getattr(channel, "entity", None) or name[:10],
            int(node),
            int(direction or 0),
            getattr(channel, "description", None) or "",
            True,
        )
    direction = 0 if foreign and not is_rig_channel(name) else DIRECTION_Y
    return Place(name[:10], node_of(name, order), direction, "", False)


def unplaced_line(nodes: list[int]) -> str:
    """One line for the channels of an imported recording the export numbered itself."""
    span = f"node {nodes[0]}" if len(set(nodes)) == 1 else f"nodes {min(nodes)}-{max(nodes)}"
    return (
        f"{len(nodes)} channel(s) without node or direction (the file they were imported "
        f"from gave none): written as {span} in channel order, direction 0 (none)"
    )


def _distinct_words(texts: list[str]) -> list[str]:
    """Each text's words that not every text holds (``MPS set1 Dof1``, ``MPS set1 Dof4`` ->
    ``Dof1``, ``Dof4``); the whole texts where those do not tell them apart."""
    common = set.intersection(*(set(t.split()) for t in texts))
    words = [" ".join(w for w in t.split() if w not in common) for t in texts]
    return words if all(words) and len(set(words)) == len(words) else texts


def told_apart(sets: list[dict], names: list[str]) -> list[str]:
    """``names`` of ``sets`` with records of one function type, one name and one abscissa (number
    of values and step) told apart by the first ID line (1 to 5) that is given and differs for
    each of them: ``:`` and the words of
    that line the others do not share are appended (``1+Z:Dof1``, ``1+Z:Dof4``). Records that no
    ID line tells apart keep their name (the import then asks for ``--map``)."""
    groups: dict[tuple[int, str, int, float], list[int]] = {}
    for i, (s, name) in enumerate(zip(sets, names, strict=True)):
        # records of other lengths or steps go to other points (or FRF grids): no clash there
        timing = (int(s.get("num_pts", 0)), float(s.get("abscissa_inc", 0.0)))
        groups.setdefault((int(s.get("func_type", 0)), name, *timing), []).append(i)
    out = list(names)
    for (_, name, *_), members in groups.items():
        if len(members) < 2:
            continue
        for key in ID_LINES:
            texts = [text_of(sets[i], key) for i in members]
            if all(texts) and len(set(texts)) == len(texts):
                for i, words in zip(members, _distinct_words(texts), strict=True):
                    out[i] = f"{name}:{words}"
                break
    return out
