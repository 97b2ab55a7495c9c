"""Decode a host-sim bus trace (candump log) with docs/wire.dbc and compare every value frame
with trajectory.csv: the leader's frames with `yd`, agent i's with `y{i}`, at the sample the
frame was sent in. Usage: decode_trace.py <wire.dbc> <trace.log> <trajectory.csv> <h> <agents>
Exit 0 and one summary line when every frame matches within the Q7.16 resolution."""
import csv
import sys

import can
import cantools

RESOLUTION = 2.0 ** -16


def main():
    dbc, log, traj, h, agents = sys.argv[1:6]
    h, agents = float(h), int(agents)
    db = cantools.database.load_file(dbc)
    leader_id = db.get_message_by_name("Leader").frame_id
    with open(traj, newline="") as f:
        rows = list(csv.DictReader(f))
    checked, worst, samples = 0, 0.0, set()
    for msg in can.LogReader(log):
        decoded = db.decode_message(msg.arbitration_id, msg.data)
        # A frame ends within the sample it was submitted in (no deadline miss in the run).
        k = int(msg.timestamp / h)
        source = msg.arbitration_id - leader_id
        column = "yd" if source == 0 else f"y{source}"
        if not 0 <= source <= agents:
            sys.exit(f"frame with unexpected id {msg.arbitration_id:#x}")
        if decoded["no_value"] or decoded["saturated"]:
            sys.exit(f"unexpected flags in {msg}")
        if decoded["seq"] != k % 64:
            sys.exit(f"{msg}: sequence counter {decoded['seq']}, expected {k % 64}")
        want = float(rows[k][column])
        err = abs(decoded["y"] - want)
        worst = max(worst, err)
        if err > RESOLUTION:
            sys.exit(f"{msg}: y = {decoded['y']} but {column}[{k}] = {want} (|diff| {err})")
        checked += 1
        samples.add(k)
    expected = len(samples) * (agents + 1)
    if checked != expected or len(samples) < len(rows) - 1:
        sys.exit(f"{checked} frames over {len(samples)} samples of {len(rows)}: frames missing")
    print(f"decoded {checked} frames over {len(samples)} samples; max |y - csv| = {worst:.3e}")


if __name__ == "__main__":
    main()
