"""The client a call runs on, and running a list of delayed tasks on it."""

from __future__ import annotations

import os
from typing import Any

try:
    import dask
    import distributed
except ImportError as _e:  # pragma: no cover - depends on the environment
    raise ImportError(
        "flakescatter.dask needs Dask: pip install 'flakescatter[dask]' "
        "(dask and distributed of the same version)"
    ) from _e


def client_of(client: Any) -> Any:
    """The client given, else the current default client, else ``None`` (threads)."""
    if client is not None:
        return client
    try:
        return distributed.default_client()
    except ValueError:
        return None


def threads(client: Any) -> int:
    """Worker threads of ``client`` (this machine's cores for the threaded scheduler)."""
    if client is None:
        return os.cpu_count() or 1
    return max(1, sum(client.nthreads().values()))


def compute(client: Any, tasks: list) -> list:
    """The results of ``tasks`` (delayed), in order; on an error or an interrupt the
    tasks still queued on the cluster are cancelled."""
    if client is None:
        return list(dask.compute(*tasks, scheduler="threads"))
    futures = client.compute(tasks)
    try:
        return list(client.gather(futures))
    except BaseException:
        client.cancel(futures)
        raise


def delayed(fn, *args, key: str, pure: bool):
    """``fn(*args)`` as a delayed task named ``key`` (the dashboard's name)."""
    return dask.delayed(fn, pure=pure)(*args, dask_key_name=key)
