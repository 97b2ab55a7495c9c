#!/usr/bin/env python3
"""Commission one NUCLEO-G474RE node over CAN with the Python `canopen` package (PyPI), from
the EDS `host-sim nodes SCENARIO --out DIR` writes for agent i (DIR/agent-<i>.eds: the
object dictionary with agent i's values as DefaultValue):

    python3 boards/nucleo-g474re/commission.py DIR/agent-2.eds 2            # board on can0
    python3 boards/nucleo-g474re/commission.py DIR/agent-2.eds 2 --dry-run  # print the writes

With the board alone on the bus (an unconfigured board answers as node-ID 4, the default;
--node-id for another), in NMT pre-operational: every writable entry from 0x2000 is written
with the EDS's value (a refused write is retried once after the others, as the node's own
load does, then reported), then node.node_id = i, 0x1010 "save" (the board writes its flash
page), NMT reset node; the board restarts as node-ID i and its boot-up and heartbeat
(PRE-OPERATIONAL) are checked, and its graph entries (graph.neighbours, graph.pinned: read
only, from the plan compiled into the image) against the scenario's. Exit status 1 on the
first failure.
"""

import argparse
import sys
import time

import canopen

NODE_ID_KEY = "node.node_id"


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
            out.append((obj.index, v.subindex, v.name, v))
    return out


def graph(od):
    """(index, sub-index, name, variable) of the read-only graph entries: the image's plan."""
    out = []
    for obj in od.values():
        if obj.index < 0x2000 or not obj.name.startswith("graph."):
            continue
        if isinstance(obj, canopen.objectdictionary.ODVariable):
            out.append((obj.index, 0, obj.name, obj))
        else:
            out += [(obj.index, v.subindex, f"{obj.name}[{v.subindex}]", v) for v in obj.values()]
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
    if a.dry_run:
        for index, sub, name, v in plan:
            print(f"{index:#06x}/{sub} {name} = {v.default}")
        print(f"{od[NODE_ID_KEY].index:#06x}/0 {NODE_ID_KEY} = {a.agent}; store; reset node")
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

    board.sdo[NODE_ID_KEY].raw = a.agent
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
        print("the image's plan is not the scenario's graph (rebuild with it in src/config.rs): "
              + "; ".join(differ), file=sys.stderr)
        return 1
    print(f"node-ID {a.agent}: stored, restarted, PRE-OPERATIONAL")
    return 0


if __name__ == "__main__":
    sys.exit(main())
