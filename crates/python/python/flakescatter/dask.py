"""flakescatter on a Dask cluster: big maps split over workers, and many samples.

Needs the optional extra ``pip install flakescatter[dask]`` (``dask`` and
``distributed`` of the same version).

* :func:`topographic_model` and :func:`isotropic_model` take a Zarr v3 height-map store
  (or several) instead of :class:`~flakescatter.Map` objects, with the keywords and the
  result of :func:`flakescatter.topographic_model` / :func:`flakescatter.isotropic_model`.
  The store's statistics tiles (``tile_um``) are split into ranges; each task traces one
  range on a worker, reading only the bands of the store its tiles and their window's
  halo touch, and returns its per-tile sums; the client reduces the sums in tile order,
  exactly as one process does, so the result is that of ``flakescatter topo`` on the same
  store, bit for bit (docs/guide.md "Big maps on Dask"). Every worker must see the store
  at the same path (a shared file system).
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

from __future__ import annotations

import json
import math
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import uuid
from typing import Any, Iterable, Sequence, Union

try:
    import dask
    import distributed
except ImportError as _e:  # pragma: no cover - depends on the environment
    raise ImportError(
        "flakescatter.dask needs Dask: pip install 'flakescatter[dask]' "
        "(dask and distributed of the same version)"
    ) from _e

from . import _flakescatter as _fs

__all__ = ["topographic_model", "isotropic_model", "analyze_many", "tile_ranges"]

PathLike = Union[str, "os.PathLike[str]"]

#: Tasks per worker thread when ``tiles_per_task`` is not given: enough for Dask to
#: balance the load and to lose little when a worker dies.
TASKS_PER_THREAD = 4


def _client(client: Any) -> Any:
    """The client given, else the current default client, else ``None`` (threads)."""
    if client is not None:
        return client
    try:
        return distributed.default_client()
    except ValueError:
        return None


def _threads(client: Any) -> int:
    if client is None:
        return os.cpu_count() or 1
    return max(1, sum(client.nthreads().values()))


def tile_ranges(tiles: int, per_task: int) -> list:
    """Consecutive ranges ``(start, stop)`` of ``per_task`` tiles covering ``0..tiles``."""
    if per_task < 1:
        raise _fs.InputError(f"tiles_per_task={per_task}: expected at least 1")
    return [(a, min(a + per_task, tiles)) for a in range(0, tiles, per_task)]


def _stores(store: Any) -> list:
    if isinstance(store, (str, os.PathLike)):
        return [os.fspath(store)]
    try:
        out = [os.fspath(s) for s in store]
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
    # Opened and checked here, before any task: a bad store or keyword is raised now.
    run = _fs.StoreRun(stores, isotropic=isotropic, **keywords)
    tiles = run.tile_count()
    client = _client(client)
    if tiles_per_task is None:
        tiles_per_task = max(1, math.ceil(tiles / (TASKS_PER_THREAD * _threads(client))))
    elif not isinstance(tiles_per_task, int) or isinstance(tiles_per_task, bool):
        raise _fs.InputError(f"tiles_per_task={tiles_per_task!r}: expected an integer >= 1")
    ranges = tile_ranges(tiles, tiles_per_task)
    model = "isotropic" if isotropic else "topo"
    token = uuid.uuid4().hex[:8]
    tasks = [
        dask.delayed(_trace, pure=True)(
            stores,
            isotropic,
            keywords,
            a,
            b,
            dask_key_name=f"flakescatter-{model}-tiles-{token}-{a}-{b}",
        )
        for a, b in ranges
    ]
    if client is None:
        parts = list(dask.compute(*tasks, scheduler="threads"))
    else:
        parts = client.gather(client.compute(tasks))
    return run.finish(list(parts))


def topographic_model(
    store: Union[PathLike, Sequence[PathLike]],
    *,
    client: Any = None,
    tiles_per_task: Union[int, None] = None,
    **keywords: Any,
) -> dict:
    """:func:`flakescatter.topographic_model` over Zarr v3 store(s), split over Dask.

    ``store``: a store's path or a sequence of them (several maps, accumulated as
    ``topographic_model`` accumulates them). ``keywords``: those of
    :func:`flakescatter.topographic_model` (``window``, ``tile_um``, ``n``, ``theta_i``,
    ``theta_s``, ``detectors``, ``aperture``, ``transmission``, ``weighting``,
    ``clearcoat``, ``flake_index``, ``flake_stack``, ``flake_core``,
    ``wavelength_nm``), plus ``intensity_cutoff`` (points whose intensity in the store's
    ``intensity`` array, or in ``intensity_store``'s, is below it are masked, as
    ``topo --intensity-cutoff``). ``tiles_per_task``: statistics tiles per task (default:
    about four tasks per worker thread). Returns the dict ``topographic_model`` returns
    (the same keys and numbers, bit for bit, as ``flakescatter topo`` on the store).
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


# --------------------------------------------------------------------------- analyze


def _cli(cli: Union[PathLike, None]) -> str:
    """The ``flakescatter`` executable (on the worker that runs the task)."""
    if cli is not None:
        return os.fspath(cli)
    env = os.environ.get("FLAKESCATTER_CLI")
    if env:
        return env
    found = shutil.which("flakescatter")
    if found is None:
        raise _fs.FileError(
            "the flakescatter command line was not found: give cli=PATH, set "
            "$FLAKESCATTER_CLI, or put `flakescatter` on the workers' PATH "
            "(cargo install --path crates/cli)"
        )
    return found


def _error_text(stderr: str) -> str:
    """The CLI's error (its `error:` lines), else the whole of stderr."""
    lines = [l for l in stderr.splitlines() if l.strip()]
    at = next((k for k, l in enumerate(lines) if l.startswith("error")), None)
    return "\n".join(lines[at:] if at is not None else lines) or "no message"


def _analyze_one(cli: Union[str, None], manifest: str, out: str, preview: bool) -> dict:
    """One task: ``flakescatter analyze MANIFEST --out OUT`` (on a worker)."""
    outcome = {"manifest": manifest, "dir": out}
    try:
        exe = _cli(cli)
    except _fs.Error as e:
        return {**outcome, "error": str(e)}
    argv = [exe, "analyze", manifest, "--out", out, "--json"]
    if not preview:
        argv.append("--no-preview")
    env = dict(os.environ)
    # The preview renders through this package's flakescatter.mitsuba: the worker's own
    # Python, unless the worker's environment names another.
    env.setdefault("FLAKESCATTER_PYTHON", sys.executable)
    try:
        r = subprocess.run(argv, capture_output=True, text=True, env=env)
    except OSError as e:
        return {**outcome, "error": f"cannot run {exe}: {e}"}
    if r.returncode != 0:
        return {**outcome, "error": _error_text(r.stderr), "exit_status": r.returncode}
    echo = json.loads(r.stdout)["samples"][0]
    summary = pathlib.Path(out) / "summary.json"
    return {
        **outcome,
        "sample": echo["sample"],
        "work": echo["work"],
        "warnings": echo["warnings"],
        "summary": str(summary),
    }


#: The file that marks a directory as an ``analyze_many`` output (it lists the samples).
MARKER = "analyze_many.json"
#: The comparison files written into ``out_dir``.
COMPARISON_FILES = ("samples.csv", "index.md", "index.html")


def _check_out_dir(out: pathlib.Path, names: Iterable[str]) -> set:
    """``out_dir`` must be missing, empty, or an earlier ``analyze_many`` output holding
    nothing else (refused before any work). Returns the earlier run's sample folders."""
    if not out.exists():
        return set()
    if not out.is_dir():
        raise _fs.InputError(f"out_dir {out}: exists and is not a directory")
    items = {p.name for p in out.iterdir()}
    if not items:
        return set()
    if MARKER not in items:
        raise _fs.InputError(
            f"out_dir {out}: not empty and not an earlier analyze_many output "
            f"(no {MARKER}): give a new or empty directory"
        )
    try:
        earlier = set(json.loads((out / MARKER).read_text())["samples"])
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise _fs.InputError(f"out_dir {out}: {MARKER} is unreadable: {e}") from None
    others = items - earlier - set(COMPARISON_FILES) - {MARKER} - set(names)
    if others:
        raise _fs.InputError(
            f"out_dir {out}: holds files analyze_many did not write ({', '.join(sorted(others))})"
        )
    return earlier


def _write(path: pathlib.Path, text: str) -> None:
    """Writes ``text`` atomically (a temporary file in the same folder, renamed)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _manifests(items: Union[PathLike, Sequence[PathLike]]) -> list:
    if isinstance(items, (str, os.PathLike)):
        items = [items]
    out = []
    for it in items:
        p = pathlib.Path(it)
        if p.is_dir():
            found = sorted(q for q in p.iterdir() if q.suffix == ".toml" and q.is_file())
            if not found:
                raise _fs.InputError(f"manifests: {p} holds no .toml manifest")
            out.extend(found)
        else:
            out.append(p)
    if not out:
        raise _fs.InputError("manifests: none given")
    return [p.resolve() for p in out]


def analyze_many(
    manifests: Union[PathLike, Sequence[PathLike]],
    out_dir: PathLike,
    *,
    client: Any = None,
    cli: Union[PathLike, None] = None,
    preview: bool = False,
) -> dict:
    """``flakescatter analyze`` for every manifest on the Dask workers.

    ``manifests``: manifest files (or folders of ``*.toml``). Each sample's report goes
    to ``out_dir/<name>/`` (``name``: the manifest's ``name`` key or its file name), as
    ``flakescatter analyze MANIFEST --out out_dir/<name>`` writes it, reusing what an
    earlier run left there (a rerun recomputes nothing: ``work`` in each
    ``summary.json``). A sample that fails is reported with the CLI's error and the
    others go on. Then ``out_dir`` gets the comparison across the samples that succeeded
    (``samples.csv``, ``index.md``, ``index.html``, the CLI batch's table) and
    ``analyze_many.json`` (what ran, what failed). ``preview``: render each report's
    Mitsuba preview (needs ``flakescatter[render]`` on the workers).

    Returns ``{"samples": [...], "failed": [...], "out_dir": ...}``: per sample its
    ``manifest``, ``dir``, ``sample``, ``work``, ``warnings`` and ``summary`` path; per
    failure its ``manifest``, ``dir`` and ``error``.
    """
    files = _manifests(manifests)
    out = pathlib.Path(out_dir).resolve()
    names = [_fs._sample_name(str(f)) for f in files]
    seen: dict = {}
    for f, n in zip(files, names):
        key = n.lower()
        if key in seen:
            raise _fs.InputError(
                f"samples {seen[key]} and {f} are both named `{n}` (one folder of out_dir): "
                "give one of them another `name`"
            )
        if key in {c.lower() for c in (*COMPARISON_FILES, MARKER)}:
            raise _fs.InputError(f"sample {f} is named `{n}`, a file of out_dir: rename it")
        seen[key] = f
    earlier = _check_out_dir(out, names)
    out.mkdir(parents=True, exist_ok=True)
    client = _client(client)
    cli_path = None if cli is None else os.fspath(cli)
    token = uuid.uuid4().hex[:8]
    tasks = [
        dask.delayed(_analyze_one, pure=False)(
            cli_path,
            str(f),
            str(out / n),
            preview,
            dask_key_name=f"flakescatter-analyze-{token}-{k}",
        )
        for k, (f, n) in enumerate(zip(files, names))
    ]
    if client is None:
        results = list(dask.compute(*tasks, scheduler="threads"))
    else:
        results = client.gather(client.compute(tasks))
    done = [r for r in results if "error" not in r]
    failed = [r for r in results if "error" in r]
    rows = [_comparison_row(pathlib.Path(r["summary"])) for r in done]
    csv, markdown, html = _fs._comparison_table(rows)
    if failed:
        section = "\n## Failed samples\n\n" + "".join(
            f"* `{pathlib.Path(r['manifest']).name}`: {r['error']}\n" for r in failed
        )
        markdown += section
        html = html.replace(
            "</body>",
            "<h2>Failed samples</h2><ul>"
            + "".join(
                f"<li><code>{_esc(pathlib.Path(r['manifest']).name)}</code>: {_esc(r['error'])}</li>"
                for r in failed
            )
            + "</ul></body>",
        )
    for name, text in zip(COMPARISON_FILES, (csv, markdown, html)):
        _write(out / name, text)
    record = {
        # Every sample folder in out_dir (an earlier run's stay, and stay listed).
        "samples": sorted(set(names) | earlier),
        "done": [{k: r[k] for k in ("manifest", "dir", "sample", "work")} for r in done],
        "failed": failed,
    }
    _write(out / MARKER, json.dumps(record, indent=2, sort_keys=True) + "\n")
    return {"samples": done, "failed": failed, "out_dir": str(out)}


def _comparison_row(summary: pathlib.Path) -> str:
    """A report's line of the comparison (its summary.json ``comparison_row``)."""
    try:
        row = json.loads(summary.read_text())["comparison_row"]
    except KeyError:
        raise _fs.FileFormatError(
            f"{summary}: no `comparison_row`: the flakescatter CLI the workers ran is older "
            "than this package (install both from the same source)"
        ) from None
    except (OSError, ValueError) as e:
        raise _fs.FileError(f"{summary}: cannot read the report's summary: {e}") from None
    return json.dumps(row)


def _esc(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
