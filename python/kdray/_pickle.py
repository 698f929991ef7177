"""How a :class:`kdray.Scene` travels to another process: ``pickle`` takes its tree's words and
its options (``watertight``, ``origin``), never its mesh, so the receiver validates a tree (one pass over the
words, as :meth:`kdray.Scene.load` does for a ``.kdt``) instead of building one.

With pickle protocol 5 the words go as a :class:`pickle.PickleBuffer` over the tree's own
memory: a ``buffer_callback`` (Dask's, for one) sends them out of band, without copying them
into the pickle; in band they are copied into it once. The receiver keeps them where they are
when nothing can change that memory and it lies on cache lines (another tree's words: a round
trip in the process that pickled it; an aligned ``bytes`` object), else copies them once onto
pages of their own (the writable frames a transport delivers); either way it validates them.

What arrives is data from elsewhere: anything but a whole, valid tree (truncated, damaged,
crafted, of the wrong type) is refused with a ``ValueError`` that names the problem; the
tree's checksum catches damage, validation the rest (src: core/src/format/mod.rs,
"Corruption").
"""

from __future__ import annotations

import pickle
import sys
from typing import Any, Tuple

import numpy as np

from . import _kdray

_WHAT = "a pickled kdray.Scene"


def reduce(scene: Any, protocol: int) -> Tuple[Any, Tuple[Any, ...]]:
    """``Scene.__reduce_ex__``: :func:`restore` and its arguments, the words (out of band for
    protocol 5), ``watertight`` and ``origin`` (3 floats or ``None``)."""
    words = _kdray.words(scene._tree)  # a read-only view, not a copy
    if sys.byteorder != "little":
        words = words.astype("<u4")  # a .kdt's words are little-endian
    data = pickle.PickleBuffer(words) if protocol >= 5 else words.tobytes()
    origin = None if scene.origin is None else tuple(float(x) for x in scene.origin)
    return restore, (data, scene.watertight, origin)


def restore(data: Any, watertight: Any, origin: Any = None) -> Any:
    """The scene that :func:`reduce` pickled, validated. Raises ``ValueError`` for anything
    else."""
    from . import Scene

    if type(watertight) is not bool:
        raise ValueError(f"{_WHAT}: watertight is {watertight!r}, not True or False")
    if origin is not None and not (
        type(origin) is tuple and len(origin) == 3 and all(type(x) is float for x in origin)
    ):
        raise ValueError(f"{_WHAT}: origin is {origin!r}, not None or 3 floats")
    try:
        view = memoryview(data)
    except TypeError:
        raise ValueError(
            f"{_WHAT}: the tree is a {type(data).__name__}, not bytes"
        ) from None
    if not view.c_contiguous:
        raise ValueError(f"{_WHAT}: the tree's buffer is not contiguous")
    view = view.cast("B")
    if view.nbytes % 4:
        raise ValueError(
            f"{_WHAT}: {view.nbytes} bytes is not a whole number of 4-byte words (truncated?)"
        )
    # In place when aligned; the tree keeps or copies them (src/mapped.rs) and validates them.
    words = np.require(np.frombuffer(view, dtype="<u4"), requirements="CA")
    try:
        tree = _kdray.Tree.from_words(words)
    except ValueError as e:
        raise ValueError(f"{_WHAT}: {str(e).removeprefix('data: ')}") from None
    try:
        return Scene._wrap(tree, watertight, origin)
    except ValueError as e:  # an origin that is not finite
        raise ValueError(f"{_WHAT}: {e}") from None
