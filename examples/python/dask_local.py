"""flakescatter on Dask: a shipped map as a Zarr store, traced on a LocalCluster of two
worker processes, the same numbers as the in-memory call.

Run from the repository root after ``pip install "./crates/python[dask]"``:

    python examples/python/dask_local.py

On a real cluster, replace the LocalCluster by ``Client("tcp://scheduler:8786")``
(docs/guide.md "Big maps and many samples on Dask"); every worker must see the store
at the same path.
"""

import pathlib
import tempfile

import numpy as np
from distributed import Client, LocalCluster

import flakescatter as fs
import flakescatter.dask as fsd

ROOT = pathlib.Path(__file__).resolve().parents[2]
MAP = ROOT / "fixtures" / "synth-hwhm6-rough.height.x3p"

if __name__ == "__main__":  # worker processes import this file: start the cluster once
    with tempfile.TemporaryDirectory() as tmp:
        # The map as a Zarr v3 store (a directory of chunk files), as `convert` writes it.
        store = pathlib.Path(tmp) / "layer.zarr"
        height = fs.read_map(MAP)
        fs.write_map(height, store)
        print(f"store {store.name}: {height.nx} x {height.ny} pixels")

        with LocalCluster(n_workers=2, threads_per_worker=1) as cluster, Client(cluster) as client:
            print(f"dashboard: {client.dashboard_link}")
            kw = dict(theta_i=[30], theta_s=np.arange(-70, 71, 5.0), tile_um=16.0)
            split = fsd.topographic_model(store, client=client, tiles_per_task=4, **kw)
            whole = fs.topographic_model(height, **kw)
            same = all(np.array_equal(split[k], whole[k], equal_nan=True) for k in whole)
            print(f"{len(split['brdf_per_sr'])} rows; equal to the in-memory call bit for bit: {same}")
            k = int(np.argmax(split["brdf_per_sr"]))
            print(
                f"peak BRDF {split['brdf_per_sr'][k]:.4g} /sr at theta_s "
                f"{split['theta_s_deg'][k]:g} deg ({split['rays'][k]} rays)"
            )
            if not same:
                raise SystemExit("the split run differs from the in-memory one")
