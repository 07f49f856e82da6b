"""Shared-memory slab slots: what a worker stores is what the parent loads."""

from __future__ import annotations

import numpy as np
import pytest

from shellvox.run import SlabSlots
from shellvox.voxel.slab import SlabResult

SHAPE = (3, 5, 7)


def _slab(seed: int) -> SlabResult:
    rng = np.random.default_rng(seed)
    return SlabResult(
        z_start=6, z_stop=9,
        layers=rng.integers(0, 4, SHAPE).astype(np.uint8),
        rgba=rng.integers(0, 256, (*SHAPE, 4)).astype(np.uint8),
        sdf=rng.normal(0, 1, SHAPE).astype(np.float32),
        sdf_band=rng.random(SHAPE) < 0.5,
        n_unbalanced_rows=0, n_nesting_violations=1, n_nearest_queries=2, n_distance_tests=3,
        layer_counts=np.arange(5, dtype=np.int64),
    )  # fmt: skip


@pytest.mark.parametrize(
    ("send", "pages", "kept"),
    [
        (None, None, ("layers", "rgba", "sdf", "sdf_band")),
        (("layers",), None, ("layers", "rgba", "sdf", "sdf_band")),  # no pages: all of it
        (("layers", "rgba"), {"layers.tif": [b"x"]}, ("layers", "rgba")),
        ((), {"layers.tif": [b"x"]}, ()),
    ],
)
def test_a_stored_slab_loads_equal_with_only_the_arrays_sent(send, pages, kept):
    slots = SlabSlots(2, SHAPE)
    slab = _slab(1)
    materials = np.full(SHAPE, 3, np.uint8)
    item = slots.store(1, slab, materials, None, None, pages, send)
    loaded, loaded_materials = slots.load(item)
    np.testing.assert_array_equal(loaded_materials, materials)
    for name in ("layers", "rgba", "sdf", "sdf_band"):
        array = getattr(loaded, name)
        if name in kept:
            np.testing.assert_array_equal(array, getattr(slab, name))
        else:
            assert array.size == 0 and array.dtype == getattr(slab, name).dtype
    assert loaded.n_nesting_violations == 1 and loaded.z_stop == 9
    np.testing.assert_array_equal(loaded.layer_counts, slab.layer_counts)
