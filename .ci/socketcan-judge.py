#!/usr/bin/env python3
"""Judges the runs .ci/socketcan-vm-checks.sh made in the test VM, from their summary.json files
under target/socketcan-ci/ (argument: that directory). Exit status 1 when a check fails."""
import json
import os
import sys

out = sys.argv[1] if len(sys.argv) > 1 else "target/socketcan-ci"
failed = False


def check(ok, what):
    global failed
    print(("ok   " if ok else "FAIL ") + what)
    failed |= not ok


def load(name):
    path = os.path.join(out, name, "summary.json")
    if not os.path.exists(path):
        check(False, f"{path} written")
        return None
    with open(path) as f:
        return json.load(f)


def figures(name, d):
    s = d["socketcan"]
    print(f"{name}: max error after 2Ts {d['max_error_after_predefined_time']}, "
          f"loop lateness mean {s['loop_lateness_mean_s'] * 1e6:.0f} us, "
          f"p99 {s['loop_lateness_p99_s'] * 1e6:.0f} us, max {s['loop_lateness_max_s'] * 1e6:.0f} us, "
          f"{s['loop_overruns']} overruns of {s['samples']} samples, wall {s['wall_time_s']:.1f} s")
    for a in s["agents"]:
        print(f"  agent {a['agent']}: {a['received']} commands, {a['late']} late, "
              f"{a['missing']} missing, lost at {a['lost_at_s']}, node late ticks {a['node_late_ticks']}")


ref = load("can")
sc = load("vcan")
if ref and sc:
    figures("vcan0", sc)
    check(not sc["diverged"], "vcan0: no divergence")
    e, r = sc["max_error_after_predefined_time"], ref["max_error_after_predefined_time"]
    check(e is not None and abs(e - r) <= 0.1 * r,
          f"vcan0: max error after 2Ts {e} within 10 % of kind = \"can\" ({r})")
    check(len(sc["socketcan"]["agents"]) == 4 and all("late" in a for a in sc["socketcan"]["agents"]),
          "vcan0: late and missing command frames reported per agent")
    trace = os.path.join(out, "vcan", "vcan0.log")
    n = sum(1 for _ in open(trace)) if os.path.exists(trace) else 0
    check(n > 1000, f"vcan0: candump trace of {n} frames")
    check(os.path.exists(os.path.join(out, "vcan", "socketcan.png")), "vcan0: socketcan.png")
kn = load("kill-node")
if kn:
    lost = kn["socketcan"]["agents"][2]["lost_at_s"]
    check(lost is not None, f"kill-node: agent 3 reported lost at t = {lost} s")
    state = kn["socketcan"]["agents"][2]["state"]
    check(state == "lost", f"kill-node: agent 3's state in the summary is {state!r} (lost)")
fd = load("vcan-fd")
if fd:
    figures("vcan0, CAN FD 1/4 Mbit/s, packed sensors", fd)
    check(not fd["diverged"], "vcan-fd: no divergence")
hw = load("sja1000")
if hw:
    figures("SJA1000", hw)
    check(not hw["diverged"], "SJA1000: no divergence")
sys.exit(1 if failed else 0)
