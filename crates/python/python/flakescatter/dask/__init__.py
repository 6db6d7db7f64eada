"""flakescatter on a Dask cluster: big maps split over workers, and many samples.

Needs the optional extra ``pip install flakescatter[dask]`` (``dask`` with its
``distributed`` extra, which pins ``distributed`` to dask's version).

* :func:`topographic_model` and :func:`isotropic_model` take a Zarr v3 height-map store
  (or several) instead of :class:`~flakescatter.Map` objects, with the keywords and the
  result of :func:`flakescatter.topographic_model` / :func:`flakescatter.isotropic_model`.
  The store's statistics tiles (``tile_um``) are split into ranges; each task traces one
  range on a worker, reading only the bands of the store its tiles and their window's
  halo touch, and returns its per-tile sums; the client reduces the sums in tile order,
  exactly as one process does, so the result is that of ``flakescatter topo`` on the same
  store, bit for bit (docs/guide.md "Big maps and many samples on Dask"). Every worker
  must see the store at the same absolute path (a shared file system).
* :func:`analyze_many` runs ``flakescatter analyze`` for each manifest on the workers,
  each sample's report in ``out_dir/<name>/`` (its cache there: a rerun recomputes
  nothing), a failed sample reported with its error without stopping the others, and
  writes the comparison across samples (``samples.csv``, ``index.md``, ``index.html``)
  into ``out_dir``. The workers need the ``flakescatter`` command line (``cli=``, or
  ``$FLAKESCATTER_CLI``, or ``flakescatter`` on their ``PATH``).

``client=None`` uses the current Dask client if there is one (``distributed``'s
default), else Dask's local threaded scheduler. Tasks are named ``flakescatter-…`` in the
dashboard's task stream and progress bars. A worker lost in the middle of a run costs
only its tasks, which Dask runs again elsewhere: the tasks are pure (same range, same
numbers).
"""

from ._analyze import analyze_many
from ._maps import isotropic_model, tile_ranges, topographic_model

__all__ = ["topographic_model", "isotropic_model", "analyze_many", "tile_ranges"]
