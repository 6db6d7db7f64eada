"""The topographic models over Zarr stores, split into tile ranges on the workers."""

from __future__ import annotations

import math
import os
import uuid
from typing import Any, Sequence, Union

from .. import _flakescatter as _fs
from . import _cluster

PathLike = Union[str, "os.PathLike[str]"]

#: Tasks per worker thread when ``tiles_per_task`` is not given: enough for Dask to
#: balance the load and to lose little when a worker dies.
TASKS_PER_THREAD = 4


def tile_ranges(tiles: int, per_task: int) -> list:
    """Consecutive ranges ``(start, stop)`` of ``per_task`` tiles covering ``0..tiles``."""
    if isinstance(per_task, bool) or not isinstance(per_task, int) or per_task < 1:
        raise _fs.InputError(f"tiles_per_task={per_task!r}: expected an integer >= 1")
    return [(a, min(a + per_task, tiles)) for a in range(0, tiles, per_task)]


def _stores(store: Any) -> list:
    """Absolute store paths: a worker runs in another directory than the client."""
    if isinstance(store, (str, os.PathLike)):
        return [os.path.abspath(os.fspath(store))]
    try:
        out = [os.path.abspath(os.fspath(s)) for s in store]
    except TypeError:
        raise _fs.InputError(
            "store: expected a Zarr store's path or a sequence of them"
        ) from None
    if not out:
        raise _fs.InputError("store: no Zarr store given")
    return out


def _trace(stores: list, isotropic: bool, keywords: dict, start: int, stop: int) -> dict:
    """One task: the per-tile sums of tiles ``start..stop`` (on a worker)."""
    run = _fs.StoreRun(stores, isotropic=isotropic, **keywords)
    return run.trace(start, stop)


def _run(store, isotropic: bool, client, tiles_per_task, keywords: dict) -> dict:
    stores = _stores(store)
    keywords = dict(keywords)
    if keywords.get("intensity_store") is not None:
        keywords["intensity_store"] = os.path.abspath(os.fspath(keywords["intensity_store"]))
    # Opened and checked here, before any task: a bad store or keyword is raised now.
    run = _fs.StoreRun(stores, isotropic=isotropic, **keywords)
    tiles = run.tile_count()
    client = _cluster.client_of(client)
    if tiles_per_task is None:
        tiles_per_task = max(1, math.ceil(tiles / (TASKS_PER_THREAD * _cluster.threads(client))))
    ranges = tile_ranges(tiles, tiles_per_task)
    model = "isotropic" if isotropic else "topo"
    token = uuid.uuid4().hex[:8]
    tasks = [
        _cluster.delayed(
            _trace, stores, isotropic, keywords, a, b,
            key=f"flakescatter-{model}-tiles-{token}-{a}-{b}", pure=True,
        )
        for a, b in ranges
    ]
    return run.finish(_cluster.compute(client, tasks))


def topographic_model(
    store: Union[PathLike, Sequence[PathLike]],
    *,
    client: Any = None,
    tiles_per_task: Union[int, None] = None,
    **keywords: Any,
) -> dict:
    """:func:`flakescatter.topographic_model` over Zarr v3 store(s), split over Dask.

    ``store``: a store's path or a sequence of them (several maps, accumulated as
    ``topographic_model`` accumulates them; relative paths are taken from the client's
    working directory). ``keywords``: those of :func:`flakescatter.topographic_model`
    (``window``, ``tile_um``, ``n``, ``theta_i``, ``theta_s``, ``detectors``,
    ``aperture``, ``transmission``, ``weighting``, ``clearcoat``, ``flake_index``,
    ``flake_stack``, ``flake_core``, ``wavelength_nm``), plus ``intensity_cutoff`` (points
    whose intensity in the store's ``intensity`` array, or in ``intensity_store``'s, is
    below it are masked, as ``topo --intensity-channel intensity --cutoff`` /
    ``--intensity I.zarr --cutoff``). ``tiles_per_task``: statistics tiles per task
    (default: about four tasks per worker thread). Returns the dict
    ``topographic_model`` returns (the same keys and numbers, bit for bit, as
    ``flakescatter topo`` on the store).
    """
    return _run(store, False, client, tiles_per_task, keywords)


def isotropic_model(
    store: Union[PathLike, Sequence[PathLike]],
    *,
    client: Any = None,
    tiles_per_task: Union[int, None] = None,
    **keywords: Any,
) -> dict:
    """:func:`flakescatter.isotropic_model` over Zarr v3 store(s), split over Dask.

    As :func:`topographic_model`, with the keywords of
    :func:`flakescatter.isotropic_model` (``node_spacing_deg`` …); the result has its
    ``interpolation_error`` column too (equal to ``flakescatter topo --isotropic``'s).
    """
    return _run(store, True, client, tiles_per_task, keywords)
