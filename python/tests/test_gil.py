"""The GIL is released while the library computes: other Python threads keep running."""

import threading
import time

import powertwin as pt


def test_simulate_releases_the_gil(robot, work):
    plan = work["plans"][0]
    start = time.perf_counter()
    pt.simulate(robot, plan, seed=1)
    call = time.perf_counter() - start
    worker = threading.Thread(target=pt.simulate, args=(robot, plan), kwargs={"seed": 1})
    ticks = []
    worker.start()
    while worker.is_alive():
        ticks.append(time.perf_counter())
    worker.join()
    gaps = [b - a for a, b in zip(ticks, ticks[1:])]
    # Holding the GIL, the main thread would stop for the whole call (one gap of ~`call`).
    assert max(gaps) < 0.5 * call, f"main thread stalled {max(gaps):.3f} s of a {call:.3f} s call"
