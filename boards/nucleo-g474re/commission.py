#!/usr/bin/env python3
"""Commission one NUCLEO-G474RE node over CAN with the Python `canopen` package (PyPI), from
the EDS `host-sim nodes SCENARIO --out DIR` writes for agent i (DIR/agent-<i>.eds: the
object dictionary with agent i's values as DefaultValue):

    python3 boards/nucleo-g474re/commission.py DIR/agent-2.eds 2            # board on can0
    python3 boards/nucleo-g474re/commission.py DIR/agent-2.eds 2 --dry-run  # print the writes

With the board alone on the bus (an unconfigured board answers as node-ID 4, the default;
--node-id for another), in NMT pre-operational: the identifier plan (node.agents,
node.id_base, node.heartbeat_id_base) and the graph row of agent i from the scenario's
[graph] (the EDS's graph.neighbours and graph.pinned; a scenario without heartbeat identifiers keeps
the board's, which its heartbeat needs) are written first — pinned, the row
emptied, its entries, its count, then pinned as the scenario says, so that no step is a row
the node refuses — then every other writable entry from 0x2000 with the EDS's value (a
refused write is retried once after the others, as the node's own load does, then
reported), then node.node_id = i, 0x1010 "save" (the board writes its flash page), NMT reset
node; the board restarts as node-ID i (its acceptance filters on the stored row) and its
boot-up and heartbeat (PRE-OPERATIONAL) are checked, and the row and plan read back against
the scenario's. Exit status 1 on the first failure.
"""

import argparse
import sys
import time

import canopen

NODE_ID_KEY = "node.node_id"
ROW_KEY = "graph.neighbours"
PINNED_KEY = "graph.pinned"
PLAN_KEYS = ("node.agents", "node.id_base", "node.heartbeat_id_base")
NO_HEARTBEAT_IDS = 0xFFFF


def writes(od):
    """(index, sub-index, name, value) of every writable manufacturer entry with a value."""
    out = []
    for obj in od.values():
        if obj.index < 0x2000:
            continue
        if isinstance(obj, canopen.objectdictionary.ODVariable):
            variables = [obj]
        else:
            variables = [v for v in obj.values() if v.subindex > 0]
        for v in variables:
            if "w" not in v.access_type or v.default is None or v.name == NODE_ID_KEY:
                continue
            if obj.name in (ROW_KEY, PINNED_KEY) or obj.name in PLAN_KEYS:
                continue
            out.append((obj.index, v.subindex, v.name, v))
    return out


def plan_keys(od):
    """The plan's keys to write: a scenario without heartbeat identifiers (0xFFFF) leaves the
    board's own (it sends a heartbeat, which needs them)."""
    return [k for k in PLAN_KEYS
            if not (k == "node.heartbeat_id_base" and od[k].default == NO_HEARTBEAT_IDS)]


def row_writes(od, agent):
    """(index, sub-index, name, raw bytes) that make the board agent `agent` with the plan and
    graph row of the EDS, in an order the node accepts at every step: pinned and the row
    emptied (nothing to conflict with), the node-ID (applied at the reset), the plan, the
    entries, their count, pinned as the scenario says."""
    row, pinned, node_id = od[ROW_KEY], od[PINNED_KEY], od[NODE_ID_KEY]
    count = row[0].default
    entries = [row[k].default for k in range(1, count + 1)]
    out = [
        (pinned.index, 0, PINNED_KEY, pinned.encode_raw(True)),
        (row.index, 0, f"{ROW_KEY}[0]", row[0].encode_raw(0)),
        (node_id.index, 0, NODE_ID_KEY, node_id.encode_raw(agent)),
    ]
    for key in plan_keys(od):
        v = od[key]
        out.append((v.index, 0, key, v.encode_raw(v.default)))
    for k, agent in enumerate(entries, start=1):
        out.append((row.index, k, f"{ROW_KEY}[{k}]", row[k].encode_raw(agent)))
    out.append((row.index, 0, f"{ROW_KEY}[0]", row[0].encode_raw(count)))
    out.append((pinned.index, 0, PINNED_KEY, pinned.encode_raw(bool(pinned.default))))
    return out


def graph(od):
    """(index, sub-index, name, variable) of the plan and of the graph row heard: what the
    board reads back after the reset."""
    row = od[ROW_KEY]
    out = [(od[k].index, 0, k, od[k]) for k in plan_keys(od) + [PINNED_KEY]]
    out.append((row.index, 0, f"{ROW_KEY}[0]", row[0]))
    out += [(row.index, k, f"{ROW_KEY}[{k}]", row[k]) for k in range(1, row[0].default + 1)]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("eds", help="DIR/agent-<i>.eds from host-sim nodes")
    ap.add_argument("agent", type=int, help="the agent i the board becomes (its node-ID)")
    ap.add_argument("--node-id", type=int, default=4, help="the board's node-ID now (default 4)")
    ap.add_argument("--interface", default="socketcan")
    ap.add_argument("--channel", default="can0")
    ap.add_argument("--dry-run", action="store_true", help="print the writes, touch no bus")
    a = ap.parse_args()

    od = canopen.import_od(a.eds)
    plan = writes(od)
    first = row_writes(od, a.agent)
    if a.dry_run:
        for index, sub, name, raw in first:
            print(f"{index:#06x}/{sub} {name} = 0x{raw.hex()} (little-endian)")
        for index, sub, name, v in plan:
            print(f"{index:#06x}/{sub} {name} = {v.default}")
        print("store; reset node")
        for index, sub, name, v in graph(od):
            print(f"expected after the reset: {index:#06x}/{sub} {name} = {v.default}")
        return 0

    network = canopen.Network()
    network.connect(interface=a.interface, channel=a.channel)
    board = canopen.RemoteNode(a.node_id, od)
    network.add_node(board)
    state = board.nmt.wait_for_heartbeat(5)
    if state != "PRE-OPERATIONAL":
        print(f"node {a.node_id}: {state}, not PRE-OPERATIONAL", file=sys.stderr)
        return 1

    for index, sub, name, raw in first:
        try:
            board.sdo.download(index, sub, raw)
        except canopen.SdoAbortedError as e:
            print(f"{index:#06x}/{sub} {name} = 0x{raw.hex()} refused: {e.code:#010x}",
                  file=sys.stderr)
            return 1
    print(f"node-ID, identifier plan and graph row written ({len(first)} writes)")

    refused = []
    for index, sub, name, v in plan:
        try:
            board.sdo.download(index, sub, v.encode_raw(v.default))
        except canopen.SdoAbortedError:
            refused.append((index, sub, name, v))
    for index, sub, name, v in refused:
        try:
            board.sdo.download(index, sub, v.encode_raw(v.default))
        except canopen.SdoAbortedError as e:
            print(f"{index:#06x}/{sub} {name} = {v.default} refused: {e.code:#010x}", file=sys.stderr)
            return 1
    print(f"{len(plan)} entries written")

    board.store()
    time.sleep(0.5)  # the board erases and programs its page (some 25 ms) in its idle task
    # Listen for the boot-up of the new node-ID before the reset: it follows at once.
    bootups = []
    network.subscribe(0x700 + a.agent, lambda cob, data, ts: bootups.append(bytes(data)))
    board.nmt.state = "RESET"
    end = time.monotonic() + 10
    while b"\x00" not in bootups and time.monotonic() < end:
        time.sleep(0.05)
    if b"\x00" not in bootups:
        print(f"no boot-up of node {a.agent} within 10 s of the reset", file=sys.stderr)
        return 1
    network.nodes.pop(a.node_id, None)
    node = canopen.RemoteNode(a.agent, od)
    network.add_node(node)
    state = node.nmt.wait_for_heartbeat(5)
    got = node.sdo[NODE_ID_KEY].raw
    differ = []
    for index, sub, name, v in graph(od):
        value = v.decode_raw(node.sdo.upload(index, sub))
        if value != v.default:
            differ.append(f"{name} = {value}, the scenario {v.default}")
    network.disconnect()
    if state != "PRE-OPERATIONAL" or got != a.agent:
        print(f"after the reset: node {a.agent} {state}, node.node_id = {got}", file=sys.stderr)
        return 1
    if differ:
        print("after the reset the row or plan is not the scenario's: " + "; ".join(differ),
              file=sys.stderr)
        return 1
    print(f"node-ID {a.agent}: row and plan stored, restarted, PRE-OPERATIONAL, read back")
    return 0


if __name__ == "__main__":
    sys.exit(main())
