"""Decode every line of a PIL run's traces with docs/wire.dbc: the serial-link trace
(`--link-trace`, one interface `node<i>` per agent) and the bus trace (`--trace`). The link's
CANopen frames (NMT, boot-up, heartbeats, EMCY, SDO), which the DBC does not describe, are
counted as the kind `CANopen`. Checks that
each line decodes to the message its id names, that the values are those the run exchanged
(agent numbers, word counts, finite states and reports), and that every message kind named on
the command line was decoded at least once.
Usage: decode_link_trace.py <wire.dbc> <link.log> <bus.log> <agents> <kind>...
Exit 0 and one summary line per kind when all hold."""
import math
import sys
from collections import Counter

import can
import cantools


def canopen(msg):
    """A frame of the node's CANopen device or its master (NMT, EMCY, SDO, heartbeat: the
    predefined connection set, docs/NETWORK.md §12), which wire.dbc does not describe."""
    i = msg.arbitration_id
    return not msg.is_extended_id and (
        i == 0 or 0x81 <= i <= 0xFF or 0x581 <= i <= 0x67F or 0x701 <= i <= 0x77F)


def decode(db, msg):
    m = db.get_message_by_frame_id(msg.arbitration_id | (0x80000000 if msg.is_extended_id else 0))
    if m.frame_id != msg.arbitration_id or m.is_extended_frame != msg.is_extended_id:
        sys.exit(f"{msg}: the DBC has no message with this id")
    # Sync carries dt_us only when the interval changed; the last Config word may be alone.
    return m.name, m.decode(bytes(msg.data), allow_truncated=True)


def main():
    dbc, link_log, bus_log, agents = sys.argv[1:5]
    agents = int(agents)
    required = sys.argv[5:]
    db = cantools.database.load_file(dbc)
    seen = Counter()
    words = Counter()
    for msg in can.LogReader(link_log):
        node = int(str(msg.channel).removeprefix("node"))
        if not 1 <= node <= agents:
            sys.exit(f"{msg}: unknown interface {msg.channel}")
        if canopen(msg):
            seen["CANopen"] += 1
            continue
        name, v = decode(db, msg)
        seen[name] += 1
        if name == "Config":
            words[node] += 2 if len(msg.data) == 8 else 1
        elif name == "ConfigEnd" and v["words"] != words[node]:
            sys.exit(f"node{node}: ConfigEnd says {v['words']} words, {words[node]} were sent")
        elif name == "Ready" and v["agent"] != node:
            sys.exit(f"node{node} answered Ready for agent {v['agent']}")
        elif name in ("Sync", "Report"):
            bad = [k for k, x in v.items() if isinstance(x, float) and not math.isfinite(x)]
            if bad:
                sys.exit(f"{msg}: {name} with non-finite {bad}")
        elif name == "Stats" and not 0 < v["stack_bytes"] < 65536:
            sys.exit(f"node{node}: stack high-water mark {v['stack_bytes']} B")
        elif name == "Leader" or name.startswith("Agent"):
            if v["no_value"] or not 0 <= v["seq"] < 64:
                sys.exit(f"{msg}: {name} with {v}")
    for msg in can.LogReader(bus_log):
        name, _ = decode(db, msg)
        seen["bus " + name] += 1
    missing = [k for k in required if seen[k] == 0]
    if missing:
        sys.exit(f"never decoded: {missing}; decoded: {dict(seen)}")
    for k in sorted(seen):
        print(f"{k}: {seen[k]}")


if __name__ == "__main__":
    main()
