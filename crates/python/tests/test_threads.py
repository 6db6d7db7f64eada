"""Long calls release the GIL (two model calls from two threads overlap in time) and
stop on a signal (Ctrl-C) through the facade's progress callback."""

import os
import signal
import threading
import time

import numpy as np
import pytest

import flakescatter as fs
from conftest import HEIGHT

THETA_S = np.arange(-70, 71, 5.0)


@pytest.fixture(scope="module")
def workload():
    """The fixture map, repeated in one call until the call takes at least 0.3 s on this
    machine, with small statistics tiles: 29 progress reports (batches of 256 tiles) per
    copy of the map."""
    m = fs.read_map(HEIGHT)
    ti = np.arange(0, 89, 4.0)
    maps = [m]
    while True:
        t0 = time.perf_counter()
        fs.topographic_model(maps, theta_i=ti, theta_s=THETA_S, tile_um=1.0)
        took = time.perf_counter() - t0
        if took >= 0.3 or len(maps) >= 64:
            return maps, ti, took
        maps = maps * 2


def test_two_threads_overlap(workload):
    maps, ti, took = workload
    times = {}
    a_started = threading.Event()

    def a():
        a_started.set()
        t0 = time.perf_counter()
        fs.topographic_model(maps, theta_i=ti, theta_s=THETA_S, tile_um=1.0)
        times["a"] = (t0, time.perf_counter())

    def b():
        a_started.wait()
        # Long enough for A to be inside the Rust call, short against its duration.
        time.sleep(min(0.05, took / 6))
        t0 = time.perf_counter()
        fs.distribution_model(hwhm=6.0, theta_i=ti[:5], theta_s=THETA_S)
        fs.topographic_model(maps[0], theta_i=ti[:3], theta_s=THETA_S, tile_um=1.0)
        times["b"] = (t0, time.perf_counter())

    ta, tb = threading.Thread(target=a), threading.Thread(target=b)
    ta.start(), tb.start()
    ta.join(), tb.join()
    (a0, a1), (b0, b1) = times["a"], times["b"]
    # With the GIL held through A's call, B could not run Python (its sleep's return,
    # its timestamp) until A returned: b0 would be after a1.
    assert b0 < a1, (a0, a1, b0, b1)
    assert a0 < b1


class Stop(Exception):
    pass


def test_signal_interrupts_a_long_call(workload):
    maps, ti, took = workload
    long_maps = maps * 50
    previous = signal.getsignal(signal.SIGINT)

    def handler(signum, frame):
        raise Stop()

    signal.signal(signal.SIGINT, handler)
    timer = threading.Timer(min(0.2, took / 2), os.kill, (os.getpid(), signal.SIGINT))
    try:
        t0 = time.perf_counter()
        timer.start()
        with pytest.raises(Stop):
            fs.topographic_model(long_maps, theta_i=ti, theta_s=THETA_S, tile_um=1.0)
        elapsed = time.perf_counter() - t0
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    # The full call would take about 50 × `took`; it stopped at the next batch of tiles
    # (1/29 of one map's work), with room for a loaded machine.
    assert elapsed < 10 * took + 2.0, (elapsed, took)
    # The module is usable afterwards.
    r = fs.topographic_model(maps[0], theta_i=[30], theta_s=THETA_S, tile_um=1.0)
    assert r["rays"].sum() > 0


def test_keyboard_interrupt_from_ctrl_c(workload):
    """The default SIGINT handler: Ctrl-C gives KeyboardInterrupt.

    Python installs `default_int_handler` at start-up unless SIGINT is ignored when it
    starts (a process launched in the background by a non-interactive shell, or under
    `nohup`, inherits SIG_IGN); the module must leave the handler as it found it, and
    for an inherited SIG_IGN the test installs the default one itself.
    """
    maps, ti, took = workload
    long_maps = maps * 50
    previous = signal.getsignal(signal.SIGINT)
    if previous is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    else:
        assert previous is signal.default_int_handler
    timer = threading.Timer(min(0.2, took / 2), os.kill, (os.getpid(), signal.SIGINT))
    got = None
    try:
        t0 = time.perf_counter()
        timer.start()
        try:
            fs.topographic_model(long_maps, theta_i=ti, theta_s=THETA_S, tile_um=1.0)
        except KeyboardInterrupt as e:
            got = e
        elapsed = time.perf_counter() - t0
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert isinstance(got, KeyboardInterrupt)
    assert elapsed < 10 * took + 2.0, (elapsed, took)
