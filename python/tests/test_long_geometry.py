"""Watertight mode on long geometry through the package (issue 39, items 1-2): rays from inside a
closed box of L×1×1, at shallow angles to its long walls, must all hit the box, at the exact exit
distance; whichever walk the batch takes (packets for a coherent batch, the stream for a shuffled
one). The core's walks have the same test over more meshes (tests/tests/stiff_long.rs)."""

import numpy as np
import pytest

import kdray

BOX_FACES = np.array(
    [
        [0, 2, 1], [0, 3, 2],  # z = 0
        [4, 5, 6], [4, 6, 7],  # z = 1
        [0, 1, 5], [0, 5, 4],  # y = 0
        [3, 7, 6], [3, 6, 2],  # y = 1
        [0, 4, 7], [0, 7, 3],  # x = 0
        [1, 2, 6], [1, 6, 5],  # x = L
    ],
    np.int64,
)


def long_box(length):
    """The 8 corners of [0, L]×[0, 1]×[0, 1], float32, ordered for BOX_FACES."""
    corners = [
        (0, 0, 0), (length, 0, 0), (length, 1, 0), (0, 1, 0),
        (0, 0, 1), (length, 0, 1), (length, 1, 1), (0, 1, 1),
    ]
    return np.array(corners, np.float32)


def grazing_rays(length, rng, n=512):
    """Rays from inside the box, near its middle, at sin 1e-2 … 1e-5 to the long axis, towards
    one of the four long walls; float32, with the exact exit distances in float64."""
    origins = np.column_stack(
        [length * rng.uniform(0.3, 0.7, n), rng.uniform(0.2, 0.8, n), rng.uniform(0.2, 0.8, n)]
    ).astype(np.float32)
    sines = 10.0 ** rng.uniform(-5, -2, n)
    wall = rng.integers(0, 4, n)
    axis = 1 + wall % 2
    sign = np.where(wall < 2, 1.0, -1.0)
    along = np.where(rng.integers(0, 2, n) == 0, 1.0, -1.0)
    d = np.zeros((n, 3))
    d[:, 0] = along * np.sqrt(1 - sines**2)
    d[np.arange(n), axis] = sign * sines
    directions = d.astype(np.float32)
    o, dd = origins.astype(np.float64), directions.astype(np.float64)
    lo, hi = np.zeros(3), np.array([length, 1.0, 1.0])
    with np.errstate(divide="ignore"):
        exits = np.where(dd > 0, (hi - o) / dd, np.where(dd < 0, (lo - o) / dd, np.inf))
    return origins, directions, exits.min(axis=1)


@pytest.mark.parametrize("length", [1e4, 1e5, 1e6])
@pytest.mark.parametrize("order", ["coherent", "shuffled"])
def test_watertight_rays_do_not_escape_long_boxes(length, order, rng):
    scene = kdray.Scene(long_box(length), BOX_FACES, watertight=True)
    origins, directions, exact = grazing_rays(length, rng)
    if order == "coherent":
        # Sorted by direction octant, as a camera's tiles come: the batch is traced as packets.
        key = np.lexsort(np.signbit(directions).T)
    else:
        key = rng.permutation(len(origins))
    origins, directions, exact = origins[key], directions[key], exact[key]
    hits = scene.intersect(origins, directions)
    escaped = np.flatnonzero(hits.prim < 0)
    assert escaped.size == 0, f"L = {length:g}: {escaped.size} of {len(origins)} rays escaped"
    assert np.all(np.isfinite(hits.t))
    error = np.abs(hits.t.astype(np.float64) - exact) / exact
    assert error.max() < 1e-4, f"L = {length:g}: relative t error up to {error.max():.2e}"
