"""``analyze_many``: ``flakescatter analyze`` per manifest on the workers, and the
comparison across the samples in ``out_dir``.

``out_dir`` holds ``<name>/`` per sample (each the CLI's own report folder, replaced
whole by the CLI when that sample succeeds), the comparison files and
``analyze_many.json``, which lists the sample folders (so a rerun recognises them) and
says what ran and what failed. It is written before any task, so a run stopped half-way
(an error, Ctrl-C, a lost cluster) leaves a folder the next run takes up; temporary
names the CLI and this module use while writing (``.<name>.…``) are not foreign files.
A lock file (``.analyze_many.lock``) keeps two runs out of one ``out_dir`` at a time.
"""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import uuid
from typing import Any, Sequence, Union

from .. import _flakescatter as _fs
from . import _cluster

PathLike = Union[str, "os.PathLike[str]"]

#: The file that marks a directory as an ``analyze_many`` output (it lists the samples).
MARKER = "analyze_many.json"
#: The comparison files written into ``out_dir``.
COMPARISON_FILES = ("samples.csv", "index.md", "index.html")
#: Held while a run writes ``out_dir``.
LOCK = ".analyze_many.lock"
#: The marker the CLI leaves in each report folder it owns.
CLI_MARKER = ".flakescatter-output.json"


def _cli(cli: Union[str, None]) -> str:
    """The ``flakescatter`` executable (on the worker that runs the task)."""
    if cli is not None:
        return cli
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
    lines = [line for line in stderr.splitlines() if line.strip()]
    at = next((k for k, line in enumerate(lines) if line.startswith("error")), None)
    return "\n".join(lines[at:] if at is not None else lines) or "no message"


def _analyze_one(cli: Union[str, None], manifest: str, out: str, preview: bool) -> dict:
    """One task (on a worker): ``flakescatter analyze MANIFEST --out OUT``, and the
    report's line of the comparison. Never raises: a failure is returned as ``error``."""
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
    summary = pathlib.Path(out) / "summary.json"
    try:
        echo = json.loads(r.stdout)["samples"][0]
        row = json.loads(summary.read_text())["comparison_row"]
    except (OSError, ValueError, KeyError, IndexError, TypeError) as e:
        return {
            **outcome,
            "error": f"the report of {exe} (its --json output or {summary}) is not one this "
            f"package reads ({type(e).__name__}: {e}): are the CLI and the package from "
            "the same source?",
        }
    return {
        **outcome,
        "sample": echo["sample"],
        "work": echo["work"],
        "warnings": echo["warnings"],
        "summary": str(summary),
        "row": json.dumps(row),
    }


def _known(name: str, ours: set) -> bool:
    """Whether ``name`` is one of ``out_dir``'s own entries, or a temporary of one
    (``.<entry>.…``: the CLI's report folders and this module's files being written)."""
    if name in ours:
        return True
    return name.startswith(".") and any(name.startswith(f".{o}.") for o in ours)


def _check_out_dir(out: pathlib.Path, names: Sequence[str]) -> set:
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
    ours = earlier | set(names) | set(COMPARISON_FILES) | {MARKER, LOCK}
    others = sorted(i for i in items if not _known(i, ours))
    if others:
        raise _fs.InputError(
            f"out_dir {out}: holds files analyze_many did not write ({', '.join(others)})"
        )
    return earlier


def _write(path: pathlib.Path, text: str) -> None:
    """Writes ``text`` atomically (a temporary file ``.<name>.…`` beside it, renamed)."""
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


def _record(out: pathlib.Path, samples: set, state: str, done=(), failed=()) -> None:
    record = {
        "samples": sorted(samples),
        "state": state,
        "done": [{k: r[k] for k in ("manifest", "dir", "sample", "work")} for r in done],
        "failed": list(failed),
    }
    _write(out / MARKER, json.dumps(record, indent=2, sort_keys=True) + "\n")


def _esc(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _comparison(out: pathlib.Path, done: list, failed: list) -> None:
    """``samples.csv``, ``index.md`` and ``index.html`` of the samples that succeeded
    (the CLI batch's table), the failures listed after it."""
    csv, markdown, html = _fs._comparison_table([r["row"] for r in done])
    if failed:
        def line(r):
            stale = " (its folder keeps an earlier run's report)" if r.get("earlier_report") else ""
            return pathlib.Path(r["manifest"]).name, r["error"] + stale
        items = [line(r) for r in failed]
        markdown += "\n## Failed samples\n\n" + "".join(f"* `{m}`: {e}\n" for m, e in items)
        html = html.replace(
            "</body>",
            "<h2>Failed samples</h2><ul>"
            + "".join(f"<li><code>{_esc(m)}</code>: {_esc(e)}</li>" for m, e in items)
            + "</ul></body>",
        )
    for name, text in zip(COMPARISON_FILES, (csv, markdown, html)):
        _write(out / name, text)


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
    others go on (its folder keeps an earlier run's report, if any, and says so in the
    failure). Then ``out_dir`` gets the comparison across the samples that succeeded
    (``samples.csv``, ``index.md``, ``index.html``: the table of the CLI's batch) and
    ``analyze_many.json`` (what ran, what failed); the folders of an earlier run's
    samples that this run does not hold are removed, so ``out_dir`` holds this batch.
    ``preview``: render each report's Mitsuba preview (needs ``flakescatter[render]`` on
    the workers). ``cli``: the ``flakescatter`` executable on the workers.

    Returns ``{"samples": [...], "failed": [...], "out_dir": ...}``: per sample its
    ``manifest``, ``dir``, ``sample``, ``work``, ``warnings`` and ``summary`` path; per
    failure its ``manifest``, ``dir`` and ``error``.
    """
    files = _manifests(manifests)
    out = pathlib.Path(out_dir).resolve()
    names = [_fs._sample_name(str(f)) for f in files]
    _fs._check_sample_names(names, [str(f) for f in files], [*COMPARISON_FILES, MARKER, LOCK])
    earlier = _check_out_dir(out, names)
    out.mkdir(parents=True, exist_ok=True)
    try:
        lock = os.open(out / LOCK, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        raise _fs.InputError(
            f"out_dir {out}: another analyze_many is writing it ({LOCK}; if none is, "
            "a run was killed: delete the file)"
        ) from None
    os.close(lock)
    try:
        # Before any task: a run stopped half-way leaves a folder the next run takes up.
        _record(out, earlier | set(names), "running")
        client = _cluster.client_of(client)
        cli_path = None
        if cli is not None:
            cli_path = os.fspath(cli)
            if os.sep in cli_path or (os.altsep and os.altsep in cli_path):
                cli_path = os.path.abspath(cli_path)
        token = uuid.uuid4().hex[:8]
        tasks = [
            _cluster.delayed(
                _analyze_one, cli_path, str(f), str(out / n), preview,
                key=f"flakescatter-analyze-{token}-{k}", pure=False,
            )
            for k, (f, n) in enumerate(zip(files, names))
        ]
        results = _cluster.compute(client, tasks)
        done = [r for r in results if "error" not in r]
        failed = [r for r in results if "error" in r]
        for r in failed:
            r["earlier_report"] = (pathlib.Path(r["dir"]) / "summary.json").exists()
        _comparison(out, done, failed)
        # The earlier run's samples that this batch does not hold (CLI report folders).
        for old in sorted(earlier - set(names)):
            folder = out / old
            if (folder / CLI_MARKER).is_file():
                shutil.rmtree(folder)
        left = {o for o in earlier - set(names) if (out / o).exists()}
        _record(out, set(names) | left, "complete", done, failed)
    finally:
        os.unlink(out / LOCK)
    return {"samples": done, "failed": failed, "out_dir": str(out)}
