"""Ctrl-C (SIGINT) stops a long run or sweep promptly with KeyboardInterrupt and leaves no
partial file; the interrupted sweep resumes from its journal."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import ptconsensus as pc
from conftest import EXAMPLE1

CHILD = r"""
import json, signal, sys, time
import ptconsensus as pc

# A shell without job control starts background jobs with SIGINT ignored, and Python then keeps
# it ignored: give the child the handler an interactive session has.
signal.signal(signal.SIGINT, signal.default_int_handler)

kind, scenario, out = sys.argv[1:4]
started = []

def progress(done, total):
    if not started:
        started.append(1)
        print("started", flush=True)

try:
    if kind == "run":
        pc.run(scenario, set={"simulation.t_end": 7000.0}, out=out, plots=False, decimate=1000, progress=progress)
    else:
        pc.sweep(scenario, out, axes={"controller.ts": [1.0, 2.0, 3.0, 4.0]}, set={"simulation.t_end": 2000.0}, progress=progress)
    print(json.dumps({"finished": time.time()}), flush=True)
except KeyboardInterrupt:
    print(json.dumps({"interrupted": time.time()}), flush=True)
"""


def interrupt(kind, out: Path, after: float = 0.3):
    """Starts `kind` in a child process, sends SIGINT `after` s into the run; returns the
    seconds from the signal to the KeyboardInterrupt and the child's exit status."""
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, kind, str(EXAMPLE1), str(out)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout.readline().strip() == "started"
        time.sleep(after)
        sent = time.time()
        child.send_signal(signal.SIGINT)
        line = json.loads(child.stdout.readline())
        child.wait(timeout=30)
    finally:
        child.kill()
    assert "interrupted" in line, line
    return line["interrupted"] - sent, child.returncode


def test_ctrl_c_stops_a_long_run_promptly_without_partial_files(tmp_path):
    out = tmp_path / "run"
    latency, status = interrupt("run", out)
    print(f"KeyboardInterrupt {latency * 1000:.0f} ms after SIGINT")
    assert latency < 0.5 and status == 0
    assert not out.exists(), list(out.iterdir())


def test_ctrl_c_stops_a_sweep_promptly(tmp_path):
    out = tmp_path / "sweep"
    latency, _ = interrupt("sweep", out)
    print(f"KeyboardInterrupt {latency * 1000:.0f} ms after SIGINT")
    assert latency < 0.5
    assert not (out / "results.csv").exists()
    assert not [p.name for p in out.rglob("*") if ".tmp" in p.name]


def test_an_interrupted_sweep_resumes_to_the_results_of_an_uninterrupted_one(tmp_path):
    # Runs long enough (about 50 ms of CPU each) that the interrupt, which the waiting thread
    # handles at its next poll (every 20 ms), lands while runs are still going on any machine:
    # with 3 s runs a fast build finished the sweep first.
    campaign = {"axes": {"controller.ts": [0.5, 1.0, 1.5, 2.0], "quantizer.rho": [0.8, 0.85, 0.9]}, "set": {"simulation.t_end": 60.0}}
    whole = pc.sweep(EXAMPLE1, tmp_path / "whole", progress=False, **campaign)

    def progress(done, total):
        if done == 2:  # from the sweep's journal thread; the main thread handles the signal
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt):
        pc.sweep(EXAMPLE1, tmp_path / "cut", progress=progress, **campaign)
    assert not (tmp_path / "cut" / "results.csv").exists()
    resumed = pc.sweep(EXAMPLE1, tmp_path / "cut", progress=False, **campaign)
    assert (tmp_path / "cut" / "results.csv").read_bytes() == (tmp_path / "whole" / "results.csv").read_bytes()
    assert resumed.columns == whole.columns
