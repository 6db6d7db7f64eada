"""flakescatter.dask on a LocalCluster of 2 worker processes (issue 49).

* The split topographic and isotropic runs over a Zarr store equal `flakescatter topo`
  (and `topo --isotropic`) on the same store: the CLI writes the shortest text that
  reads back to the same float, so equality of every cell is the test (1e-12 relative
  is what the issue asks; bit equality is what the reduction in tile order gives).
* A worker killed (SIGKILL) while tasks remain: Dask runs its tasks again elsewhere and
  the result equals the undisturbed run's, bit for bit.
* analyze_many over 6 manifests, one broken: 5 reports, one error naming the broken key,
  the comparison table of the 5, and a second call that recomputes nothing (`work` in
  each summary.json, the CLI's own counter).
* Bad stores (wrong dtype, missing pitch, mask of another shape, chunks that do not
  tile the array) raise flakescatter errors naming the array or attribute, before any
  task is sent.
"""

import json
import os
import pathlib
import shutil
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import flakescatter as fs

try:  # the optional extra
    import dask
    import distributed
except ImportError:  # pragma: no cover - CI installs it
    if os.environ.get("FLAKESCATTER_REQUIRE_DASK") == "1":
        raise
    pytest.skip("dask is not installed (pip install flakescatter[dask])", allow_module_level=True)
import flakescatter.dask as fsd  # noqa: E402

from conftest import FIXTURES, assert_column_equal, read_csv  # noqa: E402

COLUMNS = ["theta_i_deg", "theta_s_deg", "brdf_per_sr", "reflectance", "relative", "std_err"]


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def stores(tmp_path_factory, cli):
    """A 700 x 600 synthetic layer of 0.5 um pixels (350 x 300 um: 11 x 10 tiles of
    32 um) as a height store and a second store of its intensity."""
    d = tmp_path_factory.mktemp("stores")
    h, i = d / "layer.zarr", d / "layer-intensity.zarr"
    cli.run("synth", "--size", "700,600", "--pixel-um", "0.5", "--seed", "7", "--hwhm", "8",
            "--out", h, "--intensity-out", i)
    return h, i


def assert_rows_equal(got: dict, csv_text: str, extra=()):
    want = read_csv(csv_text)
    for k in (*COLUMNS, *extra):
        assert_column_equal(got[k], want[k], k)
    assert got["rays"].tolist() == [int(v) for v in want["rays"]]


def test_topographic_on_two_workers_equals_the_cli(client, stores, cli):
    h, i = stores
    got = fsd.topographic_model(h, client=client, intensity_cutoff=0.49, intensity_store=i,
                                theta_i=[0, 45], theta_s=np.arange(-70, 71, 2.0))
    want = cli.run("topo", h, "--intensity", i, "--cutoff", 0.49, "--theta-i", "0,45",
                   "--theta-s", "-70:70:2")
    assert_rows_equal(got, want)
    # And the in-memory binding on the store read whole.
    whole = fs.topographic_model(fs.read_map(h, intensity=i, cutoff=0.49), theta_i=[0, 45],
                                 theta_s=np.arange(-70, 71, 2.0))
    for k in COLUMNS:
        np.testing.assert_array_equal(got[k], whole[k])


def test_isotropic_on_two_workers_equals_the_cli(client, stores, cli):
    h, _ = stores
    got = fsd.isotropic_model(h, client=client, tiles_per_task=7, theta_i=[30],
                              theta_s=np.arange(-80, 81, 4.0), window=7)
    want = cli.run("topo", h, "--isotropic", "--theta-i", "30", "--theta-s", "-80:80:4",
                   "--window", 7)
    assert_rows_equal(got, want)
    # interpolation_error (not in the CLI's CSV): the in-memory binding's, on the store
    # read whole.
    whole = fs.isotropic_model(fs.read_map(h), theta_i=[30], theta_s=np.arange(-80, 81, 4.0),
                               window=7)
    for k in (*COLUMNS, "interpolation_error"):
        np.testing.assert_array_equal(got[k], whole[k])


def test_without_a_client_the_threaded_scheduler_gives_the_same_numbers(
        client, stores, monkeypatch):
    h, _ = stores
    a = fsd.topographic_model(h, client=client, theta_i=[20], tiles_per_task=3)
    # client=None takes the current default client (the cluster here): with none, Dask's
    # threaded scheduler in this process, with another split.
    from flakescatter.dask import _cluster
    monkeypatch.setattr(_cluster.distributed, "default_client",
                        lambda: (_ for _ in ()).throw(ValueError("no client")))
    assert _cluster.client_of(None) is None
    b = fsd.topographic_model(h, client=None, theta_i=[20], tiles_per_task=50)
    for k in COLUMNS:
        np.testing.assert_array_equal(a[k], b[k])


def test_a_relative_store_path_is_the_clients(client, stores, monkeypatch):
    """The workers run in another directory: the client's relative path is sent whole."""
    h, _ = stores
    want = fsd.topographic_model(h, client=client, theta_i=[40], tiles_per_task=5)
    monkeypatch.chdir(h.parent)
    got = fsd.topographic_model(h.name, client=client, theta_i=[40], tiles_per_task=5)
    for k in COLUMNS:
        np.testing.assert_array_equal(got[k], want[k])


def _scheduler_states(prefix):
    def states(dask_scheduler):
        return [ts.state for k, ts in dask_scheduler.tasks.items() if str(k).startswith(prefix)]
    return states


def test_a_worker_killed_mid_run_leaves_the_result_unchanged(client, stores):
    h, _ = stores
    kw = dict(theta_i=[0, 15, 30, 45, 60, 75], detectors=[[t, p] for t in range(0, 90, 3)
                                                        for p in range(0, 360, 15)],
              tiles_per_task=1)
    want = fsd.topographic_model(h, client=client, **kw)
    out, failure = {}, []

    def run():
        try:
            out["got"] = fsd.topographic_model(h, client=client, **kw)
        except BaseException as e:  # surfaced below
            failure.append(e)

    before = set(client.scheduler_info()["workers"])
    t = threading.Thread(target=run)
    t.start()
    killed = None
    deadline = time.monotonic() + 120
    while killed is None and time.monotonic() < deadline and t.is_alive():
        states = client.run_on_scheduler(_scheduler_states("flakescatter-topo-tiles-"))
        done = states.count("memory")
        if done >= 2 and len(states) - done >= 10:
            busy = [w for w, keys in client.processing().items() if keys]
            if busy:
                pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
                os.kill(pid, signal.SIGKILL)
                killed = (busy[0], done, len(states))
        time.sleep(0.01)
    t.join(timeout=300)
    assert not failure, failure
    assert killed is not None, "the run ended before a worker could be killed mid-run"
    _, done_at_kill, total = killed
    assert done_at_kill < total
    for k in ("brdf_per_sr", "reflectance", "relative", "std_err", "rays"):
        np.testing.assert_array_equal(out["got"][k], want[k])
    # The nanny brings a new worker up in place of the killed one.
    client.wait_for_workers(2, timeout=60)
    assert set(client.scheduler_info()["workers"]) != before


def write_manifest(path: pathlib.Path, name: str, stem: str, extra: str = "") -> pathlib.Path:
    maps = FIXTURES / f"{stem}.height.x3p"
    path.write_text(
        f'name = "{name}"\n[maps]\nfiles = ["{maps.as_posix()}"]\n'
        'intensity_suffix = ".intensity"\ncutoff = 0.49\n'
        f"[coating]\nn = 1.5\n[models]\nfit = false\n{extra}"
    )
    return path


def test_analyze_many_reports_five_one_error_and_a_rerun_recomputes_nothing(
        client, tmp_path, cli_bin):
    stems = ["synth-hwhm3-smooth", "synth-hwhm6-rough"]
    manifests = []
    for k in range(5):
        m = tmp_path / f"s{k}.toml"
        # Different coatings make different samples (n = 1.45 ... 1.65).
        write_manifest(m, f"sample{k}", stems[k % 2])
        text = m.read_text().replace("n = 1.5", f"n = {1.45 + 0.05 * k:.2f}")
        m.write_text(text)
        manifests.append(m)
    broken = tmp_path / "broken.toml"
    write_manifest(broken, "broken", stems[0])
    # A map that is not there: the CLI refuses the manifest naming the key.
    broken.write_text(broken.read_text().replace("synth-hwhm3-smooth.height", "no-such-map.height"))
    manifests.insert(2, broken)
    out = tmp_path / "many"
    first = fsd.analyze_many(manifests, out, client=client, cli=cli_bin)
    assert len(first["samples"]) == 5 and len(first["failed"]) == 1
    err = first["failed"][0]
    assert err["manifest"].endswith("broken.toml")
    assert "maps.files" in err["error"] and "no-such-map" in err["error"], err["error"]
    for r in first["samples"]:
        s = json.loads(pathlib.Path(r["summary"]).read_text())
        assert s["work"]["maps_segmented"] == 1 and not s["work"]["models_reused"]
    table = read_csv((out / "samples.csv").read_text())
    assert table["sample"] == [f"sample{k}" for k in range(5)]
    # The table is the CLI batch's over the same five manifests (its rows made in
    # memory, not read back from JSON), byte for byte.
    batch = tmp_path / "cli-batch"
    subprocess.run([str(cli_bin), "analyze", *map(str, [m for m in manifests if m != broken]),
                    "--out", str(batch), "--no-preview"], check=True, capture_output=True)
    assert (out / "samples.csv").read_text() == (batch / "samples.csv").read_text()
    assert "Failed samples" in (out / "index.md").read_text()
    assert "broken.toml" in (out / "index.md").read_text()

    csv_first = (out / "samples.csv").read_text()
    second = fsd.analyze_many(manifests, out, client=client, cli=cli_bin)
    assert len(second["samples"]) == 5 and len(second["failed"]) == 1
    for r in second["samples"]:
        s = json.loads(pathlib.Path(r["summary"]).read_text())
        w = s["work"]
        assert w["maps_segmented"] == 0 and w["maps_reused"] == 1, w
        assert w["models_reused"] and w["distribution_runs"] == 0 and w["topographic_runs"] == 0
    # The same reports from their caches: the same table.
    assert (out / "samples.csv").read_text() == csv_first


def test_analyze_many_refuses_a_foreign_out_dir_and_twin_names(tmp_path, cli_bin):
    m = write_manifest(tmp_path / "a.toml", "twin", "synth-hwhm3-smooth")
    n = write_manifest(tmp_path / "b.toml", "twin", "synth-hwhm6-rough")
    with pytest.raises(fs.InputError, match="both named `twin`"):
        fsd.analyze_many([m, n], tmp_path / "o", cli=cli_bin)
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    with pytest.raises(fs.InputError, match="not an earlier analyze_many output"):
        fsd.analyze_many([m], foreign, cli=cli_bin)
    assert (foreign / "notes.txt").read_text() == "mine"


# ----------------------------------------------------------------------- bad stores


def _edit(store: pathlib.Path, path: str, change) -> None:
    p = store / path
    meta = json.loads(p.read_text())
    change(meta)
    p.write_text(json.dumps(meta))


@pytest.fixture()
def small_store(tmp_path, cli):
    h = tmp_path / "s.zarr"
    cli.run("synth", "--size", "64", "--pixel-um", "0.5", "--out", h)
    return h


def _drop_pitch(meta):
    for k in ("pitch_x_um",):
        meta.get("attributes", {}).pop(k, None)


@pytest.mark.parametrize(
    "path, change, pattern",
    [
        ("height/zarr.json", lambda m: m.update(data_type="int32", fill_value=0),
         "array `height` has data type int32.*expected float64"),
        ("height/zarr.json", lambda m: m.update(chunk_grid={"name": "regular", "configuration": {"chunk_shape": [0, 8]}}), "array `height`"),
        ("height/zarr.json", lambda m: m.update(chunk_grid={"name": "regular", "configuration": {"chunk_shape": [8]}}), "array `height`"),
        ("zarr.json", _drop_pitch, "pitch_x_um"),
    ],
)
def test_bad_stores_are_refused_naming_the_array_or_attribute(small_store, path, change, pattern):
    _edit(small_store, path, change)
    # pitch may also sit on the array: drop it there too for the attribute case.
    if path == "zarr.json":
        _edit(small_store, "height/zarr.json", _drop_pitch)
    with pytest.raises(fs.FileFormatError, match=pattern):
        fsd.topographic_model(small_store, client=None)


def test_a_mask_of_another_shape_is_refused(small_store, tmp_path, cli):
    other = tmp_path / "other.zarr"
    cli.run("synth", "--size", "32", "--pixel-um", "0.5", "--out", other)
    shutil.copytree(other / "height", small_store / "mask")
    _edit(small_store, "mask/zarr.json", lambda m: m.update(data_type="bool", fill_value=False))
    with pytest.raises(fs.FileFormatError, match="`mask`"):
        fsd.isotropic_model(small_store, client=None)


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        (dict(tiles_per_task=0), "tiles_per_task"),
        (dict(intensity_store="x.zarr"), "intensity_store needs intensity_cutoff"),
        (dict(node_spacing_deg=1.0), "isotropic model only"),
        (dict(window=4), "window"),
        (dict(bogus=1), None),
    ],
)
def test_bad_keywords(small_store, kwargs, pattern):
    if pattern is None:
        with pytest.raises(TypeError, match="bogus"):
            fsd.topographic_model(small_store, **kwargs)
    else:
        with pytest.raises(fs.InputError, match=pattern):
            fsd.topographic_model(small_store, **kwargs)


def test_a_chunk_that_breaks_on_a_worker_raises_there_naming_the_store(client, tmp_path, cli):
    """Metadata is checked before any task; a chunk file cut short is found by the worker
    that reads it, and its error reaches the caller as the same flakescatter error."""
    h = tmp_path / "cut.zarr"
    cli.run("synth", "--size", "300", "--pixel-um", "0.5", "--out", h)
    chunk = next(p for p in (h / "height").rglob("*") if p.is_file() and p.name != "zarr.json")
    chunk.write_bytes(chunk.read_bytes()[:40])
    with pytest.raises(fs.FileFormatError, match="cut.zarr.*`height`"):
        fsd.topographic_model(h, client=client, tiles_per_task=1)


def test_a_missing_store_is_a_file_error(tmp_path):
    with pytest.raises(fs.FileError, match="nothing.zarr"):
        fsd.topographic_model(tmp_path / "nothing.zarr")


def test_analyze_many_without_a_cli_reports_each_sample_failed(tmp_path, monkeypatch):
    from flakescatter.dask import _analyze
    # The lookup a worker makes (no cli=, no $FLAKESCATTER_CLI, nothing on PATH):
    monkeypatch.delenv("FLAKESCATTER_CLI", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    with pytest.raises(fs.FileError, match="flakescatter command line was not found"):
        _analyze._cli(None)
    # A cli= that cannot run: each sample fails with the reason, none is lost.
    m = write_manifest(tmp_path / "a.toml", "solo", "synth-hwhm3-smooth")
    r = fsd.analyze_many([m], tmp_path / "o", cli=tmp_path / "no-such-flakescatter")
    assert r["samples"] == [] and len(r["failed"]) == 1
    assert "cannot run" in r["failed"][0]["error"] and "no-such-flakescatter" in r["failed"][0]["error"]


def test_analyze_many_takes_up_a_stopped_run_and_a_rerun_holds_exactly_its_samples(
        tmp_path, cli_bin):
    a = write_manifest(tmp_path / "a.toml", "alpha", "synth-hwhm3-smooth")
    b = write_manifest(tmp_path / "b.toml", "beta", "synth-hwhm6-rough")
    out = tmp_path / "o"
    fsd.analyze_many([a, b], out, cli=cli_bin, client=None)
    # What a run killed half-way leaves: a CLI temporary report folder and a temporary
    # comparison file beside their places.
    (out / ".alpha.x1y2.tmp").mkdir()
    (out / ".samples.csv.abc123").write_text("partial")
    r = fsd.analyze_many([a], out, cli=cli_bin, client=None)
    assert [s["sample"] for s in r["samples"]] == ["alpha"]
    # beta's folder (the earlier run's, not in this batch) is gone; the table is alpha's.
    assert not (out / "beta").exists() and (out / "alpha" / "summary.json").exists()
    assert read_csv((out / "samples.csv").read_text())["sample"] == ["alpha"]
    assert json.loads((out / "analyze_many.json").read_text())["state"] == "complete"
    assert not (out / ".analyze_many.lock").exists()


def test_analyze_many_refuses_an_out_dir_another_run_holds(tmp_path, cli_bin):
    a = write_manifest(tmp_path / "a.toml", "alpha", "synth-hwhm3-smooth")
    out = tmp_path / "o"
    fsd.analyze_many([a], out, cli=cli_bin, client=None)
    before = (out / "analyze_many.json").read_text()
    (out / ".analyze_many.lock").write_text("")  # a run in progress
    with pytest.raises(fs.InputError, match="another analyze_many is writing it"):
        fsd.analyze_many([a], out, cli=cli_bin, client=None)
    assert (out / "analyze_many.json").read_text() == before


def test_a_cli_whose_report_cannot_be_read_fails_that_sample_only(tmp_path):
    """A `cli=` that succeeds but prints what this package cannot read (another
    version): that sample fails saying so; the call itself ends normally."""
    fake = tmp_path / "fake-flakescatter"
    fake.write_text("#!/bin/sh\necho 'not json'\n")
    fake.chmod(0o755)
    m = write_manifest(tmp_path / "a.toml", "solo", "synth-hwhm3-smooth")
    r = fsd.analyze_many([m], tmp_path / "o", cli=fake, client=None)
    assert r["samples"] == [] and len(r["failed"]) == 1
    assert "is not one this package reads" in r["failed"][0]["error"], r["failed"][0]
