"""Shared fixtures: the repository's shipped maps and the built `flakescatter` CLI.

Every comparison in this suite runs the CLI on the same inputs and compares its
numbers with the binding's exactly: the CLI writes floats in the shortest form that
reads back to the same number, so `float(cell) == value` is the test.
"""

import csv
import io
import json
import os
import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]
FIXTURES = ROOT / "fixtures"


def _cli_path() -> pathlib.Path:
    env = os.environ.get("FLAKESCATTER_CLI")
    if env:
        return pathlib.Path(env)
    for profile in ("debug", "release"):
        p = ROOT / "target" / profile / "flakescatter"
        if p.exists():
            return p
    cargo = shutil.which("cargo")
    if cargo is None:
        pytest.exit("the flakescatter CLI is not built and cargo is not on PATH", returncode=2)
    subprocess.run([cargo, "build", "-p", "flakescatter-cli"], cwd=ROOT, check=True)
    return ROOT / "target" / "debug" / "flakescatter"


@pytest.fixture(scope="session")
def cli_bin() -> pathlib.Path:
    return _cli_path()


class Cli:
    """Runs the CLI; `run` returns stdout, `fails` the stderr of a failing run."""

    def __init__(self, path: pathlib.Path):
        self.path = path

    def run(self, *args: object) -> str:
        r = subprocess.run(
            [str(self.path), *map(str, args)], capture_output=True, text=True, cwd=ROOT
        )
        if r.returncode != 0:
            raise AssertionError(f"CLI {args} failed ({r.returncode}): {r.stderr}")
        return r.stdout

    def json(self, *args: object) -> dict:
        return json.loads(self.run(*args, "--json"))

    def fails(self, *args: object) -> str:
        r = subprocess.run(
            [str(self.path), *map(str, args)], capture_output=True, text=True, cwd=ROOT
        )
        assert r.returncode == 2, (r.returncode, r.stderr)
        return r.stderr


@pytest.fixture(scope="session")
def cli(cli_bin) -> Cli:
    return Cli(cli_bin)


def read_csv(text_or_path) -> dict:
    """A CSV as columns of strings (header → list of cells)."""
    if isinstance(text_or_path, (str,)) and "\n" in text_or_path:
        f = io.StringIO(text_or_path)
    else:
        f = open(text_or_path, newline="")
    with f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {h: [r[k] for r in body] for k, h in enumerate(header)}


def num(cell: str) -> float:
    """A CSV cell as the binding gives it: empty is NaN."""
    return float("nan") if cell == "" else float(cell)


def assert_column_equal(values, cells, name=""):
    """Exact equality of a float column and CSV cells (NaN matches an empty cell)."""
    assert len(values) == len(cells), (name, len(values), len(cells))
    for k, (v, c) in enumerate(zip(values, cells)):
        want = num(c)
        if want != want:
            assert v != v, (name, k, v, c)
        else:
            assert v == want, (name, k, v, c)


HEIGHT = FIXTURES / "synth-hwhm6-rough.height.x3p"
INTENSITY = FIXTURES / "synth-hwhm6-rough.intensity.x3p"
HEIGHT3 = FIXTURES / "synth-hwhm3-smooth.height.x3p"
INTENSITY3 = FIXTURES / "synth-hwhm3-smooth.intensity.x3p"
CUTOFF = 0.49
