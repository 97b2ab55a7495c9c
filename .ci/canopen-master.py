#!/usr/bin/env python3
"""A CANopen master nobody here wrote (the Python `canopen` package, PyPI) against node-linux
over vcan0, knowing the node only by docs/agent-node.eds. Run inside the test VM:

    cargo xtask vm -- python3 .ci/canopen-master.py target/release/node-linux target/canopen-ci

Checks: boot-up, heartbeat states, an SDO read and write-back of every generated entry the EDS
lists (0x2000..), a refused out-of-range write (abort 0x06090030, value unchanged), a write
refused outside pre-operational (0x08000022), the PDO mapping read over SDO (TPDO1 = the node's
value frame, RPDO1 the leader's, RPDO2 its neighbour's, TPDO2 its status PDO, RPDO18 the host's
sensor frame, TPDO3 its command frame) and a value frame and a command frame decoded by it,
the graph row written and read back (RPDO3 following, a duplicate refused with 0x06040043),
NMT start/stop/pre-operational, an EMCY on a forced fault (the leader silent: safe state, 0x8250), store -> restart -> the stored value,
restore -> defaults. Prints a transcript (also written to OUT/transcript.txt); exit status 1 on
the first failed check.
"""

import os
import signal
import struct
import subprocess
import sys
import time

import can
import canopen

NODE_ID = 2
EDS = "docs/agent-node.eds"


procs = []


def main():
    node_bin, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    log_lines = []

    def say(msg):
        line = f"{time.monotonic() - t0:7.3f} s  {msg}"
        print(line, flush=True)
        log_lines.append(line)

    def check(cond, what):
        say(("ok    " if cond else "FAIL  ") + what)
        if not cond:
            finish(1)

    def finish(status):
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
                try:
                    p.wait(5)
                except subprocess.TimeoutExpired:
                    p.kill()
        network.disconnect()
        with open(os.path.join(out, "transcript.txt"), "w") as f:
            f.write("\n".join(log_lines) + "\n")
        sys.exit(status)

    t0 = time.monotonic()
    store = os.path.join(out, f"agent-{NODE_ID}.od")
    if os.path.exists(store):
        os.remove(store)
    cfg = os.path.join(out, f"agent-{NODE_ID}.toml")
    with open(cfg, "w") as f:
        f.write(
            f"""[node]
agent = {NODE_ID}
neighbours = [1]
interface = "vcan0"
host_timeout = 3600.0
time_scale = 10.0
node_id = {NODE_ID}

[node.supervision]
id_base = 257
heartbeat_id_base = 1920
agents = 99
heartbeat_period_us = 100000
policy = "hold-position"
leader_timeout_us = 50000

[node.canopen]
store = "{store}"
heartbeat_ms = 100

[simulation]
h = 0.001

[agent]
neighbour_count = 1
pinned = false
"""
        )
    network = canopen.Network()
    network.connect(interface="socketcan", channel="vcan0")
    node = canopen.RemoteNode(NODE_ID, EDS)
    network.add_node(node)
    bus = network.bus
    say(f"python-canopen {canopen.__version__}, node {NODE_ID} from {EDS}")

    heartbeats = []
    network.subscribe(0x700 + NODE_ID, lambda cob, data, ts: heartbeats.append(bytes(data)))

    def start_node():
        """Starts the node process; returns once its boot-up message came."""
        heartbeats.clear()
        p = subprocess.Popen([node_bin, cfg], stderr=open(os.path.join(out, "node.log"), "a"))
        procs.append(p)
        end = time.monotonic() + 30
        while b"\x00" not in heartbeats and time.monotonic() < end:
            time.sleep(0.05)
        check(b"\x00" in heartbeats, f"boot-up message (0x{0x700 + NODE_ID:03x}: 00)")
        return p

    def stop_node(p):
        p.send_signal(signal.SIGTERM)
        p.wait(10)

    def real(index, sub=0):
        return struct.unpack("<f", node.sdo.upload(index, sub))[0]

    def abort_code(fn):
        try:
            fn()
        except canopen.SdoAbortedError as e:
            return e.code
        return None

    # Boot-up and heartbeat.
    p = start_node()
    check(node.nmt.wait_for_heartbeat(5) == "PRE-OPERATIONAL", "heartbeat: PRE-OPERATIONAL")
    check(node.sdo.upload(0x1000, 0) == bytes(4), "device type 0x1000 = 0")
    name = node.sdo.upload(0x1008, 0).decode()
    check(name == "agent-node", f"device name (segmented upload): {name!r}")

    # Every generated entry: read, write the value back, read again.
    n_rw = n_ro = 0
    for obj in node.object_dictionary.values():
        if obj.index < 0x2000:
            continue
        variables = [obj] if isinstance(obj, canopen.objectdictionary.ODVariable) else [
            v for v in obj.values() if v.subindex > 0
        ]
        for v in variables:
            raw = node.sdo.upload(obj.index, v.subindex)
            if obj.name == "graph.neighbours" and raw == b"\x00":
                # An unused entry of the graph row: 0 is no agent.
                code = abort_code(lambda: node.sdo.download(obj.index, v.subindex, raw))
                check(code == 0x06090032, f"{obj.index:#06x}/{v.subindex} unused row entry := 0 refused ({code:#010x})")
                n_rw += 1
            elif "w" in v.access_type:
                node.sdo.download(obj.index, v.subindex, raw)
                check(node.sdo.upload(obj.index, v.subindex) == raw,
                      f"{obj.index:#06x}/{v.subindex} {v.name} = {raw.hex()} written back")
                n_rw += 1
            else:
                code = abort_code(lambda: node.sdo.download(obj.index, v.subindex, raw))
                check(code == 0x06010002, f"{obj.index:#06x}/{v.subindex} {v.name} read-only ({code:#010x})")
                n_ro += 1
    say(f"{n_rw} writable and {n_ro} read-only entries round-tripped")

    # PDOs: communication and mapping parameters read over SDO (python-canopen's own reader).
    node.tpdo.read()
    node.rpdo.read()
    tpdo = node.tpdo[1]
    check(tpdo.cob_id == 0x101 + NODE_ID and tpdo.enabled and tpdo.trans_type == 254,
          f"TPDO1: COB-ID {tpdo.cob_id:#05x} (the value frame), transmission type {tpdo.trans_type}")
    lengths = [v.length for v in tpdo.map]
    check(lengths == [24, 6, 1, 1], f"TPDO1 mapping: y, sequence, saturated, no value ({lengths} bits)")
    check(node.rpdo[1].cob_id == 0x101 and node.rpdo[1].enabled, "RPDO1: the leader's 0x101")
    check(node.rpdo[2].cob_id == 0x102 and node.rpdo[2].enabled, "RPDO2: neighbour 1's 0x102")
    check(not node.rpdo[3].enabled, "RPDO3: not in use")
    status = node.tpdo[2]
    lengths = [v.length for v in status.map]
    check(status.cob_id == 0x780 + NODE_ID and lengths == [8, 8, 16, 16, 16],
          f"TPDO2: COB-ID {status.cob_id:#05x} (the status PDO), mapping {lengths} bits")
    sensor_pdo = node.rpdo[18]
    lengths = [v.length for v in sensor_pdo.map]
    check(sensor_pdo.cob_id == 0x200 + NODE_ID and sensor_pdo.enabled and lengths == [32, 32],
          f"RPDO18: COB-ID {sensor_pdo.cob_id:#05x} (the sensor frame), mapping {lengths} bits")
    command_pdo = node.tpdo[3]
    lengths = [v.length for v in command_pdo.map]
    check(command_pdo.cob_id == 0x300 + NODE_ID and command_pdo.enabled and lengths == [32, 32],
          f"TPDO3: COB-ID {command_pdo.cob_id:#05x} (the command frame), mapping {lengths} bits")

    # The graph row over SDO: agent 2 to hear agents 1 and 3 (entry 2, then the count), read
    # back with RPDO3 following; a duplicate refused, the row unchanged; then agent 1 alone
    # again. A written row applies at the next reset communication: a start before it is
    # refused (EMCY 0x6300, back to pre-operational).
    row = node.object_dictionary["graph.neighbours"].index
    node.sdo.download(row, 2, bytes([3]))
    node.sdo.download(row, 0, bytes([2]))
    check(node.sdo.upload(row, 0) == b"\x02" and node.sdo.upload(row, 2) == b"\x03",
          "graph.neighbours := [1, 3] read back")
    cob = struct.unpack("<I", node.sdo.upload(0x1402, 1))[0]
    check(cob == 0x104, f"RPDO3 follows the row: COB-ID {cob:#05x} (agent 3's value frame)")
    code = abort_code(lambda: node.sdo.download(row, 2, bytes([1])))
    check(code == 0x06040043, f"graph.neighbours[2] := 1 (a duplicate) refused with {code:#010x}")
    check(node.sdo.upload(row, 2) == b"\x03", "graph.neighbours[2] still 3")
    node.sdo.download(row, 0, bytes([1]))
    check(node.sdo.upload(row, 0) == b"\x01", "graph.neighbours back to [1]")
    node.emcy.reset()
    node.nmt.state = "OPERATIONAL"
    time.sleep(0.3)
    state = node.nmt.wait_for_heartbeat(5)
    codes = [e.code for e in node.emcy.log]
    check(state == "PRE-OPERATIONAL" and 0x6300 in codes,
          f"NMT start with a written row waiting: refused, {state}, EMCY "
          + ", ".join(f"{c:#06x}" for c in codes))
    node.nmt.state = "RESET COMMUNICATION"
    time.sleep(0.5)
    check(node.nmt.wait_for_heartbeat(5) == "PRE-OPERATIONAL" and node.sdo.upload(row, 0) == b"\x01",
          "reset communication: the row [1] applied, pre-operational")

    zeta = node.object_dictionary["controller.zeta"].index
    node.sdo[zeta].raw = 0.2
    check(abs(real(zeta) - 0.2) < 1e-7, "controller.zeta := 0.2")
    code = abort_code(lambda: node.sdo.download(zeta, 0, struct.pack("<f", 1.5)))
    check(code == 0x06090030, f"controller.zeta := 1.5 refused with {code:#010x}")
    check(abs(real(zeta) - 0.2) < 1e-7, "controller.zeta still 0.2")

    # NMT.
    node.nmt.state = "OPERATIONAL"
    time.sleep(0.3)
    check(node.nmt.wait_for_heartbeat(5) == "OPERATIONAL", "NMT start: heartbeat OPERATIONAL")
    code = abort_code(lambda: node.sdo.download(zeta, 0, struct.pack("<f", 0.3)))
    check(code == 0x08000022, f"write while operational refused with {code:#010x}")
    node.nmt.state = "STOPPED"
    time.sleep(0.3)
    check(node.nmt.wait_for_heartbeat(5) == "STOPPED", "NMT stop: heartbeat STOPPED")
    node.nmt.state = "PRE-OPERATIONAL"
    time.sleep(0.3)
    check(node.nmt.wait_for_heartbeat(5) == "PRE-OPERATIONAL", "NMT pre-operational")

    # A forced fault: sensor frames come (the node samples), the leader stays silent longer
    # than leader_timeout once started: safe state, EMCY 0x8250 (RPDO timeout).
    node.emcy.reset()
    node.nmt.state = "OPERATIONAL"
    sensor = can.Message(arbitration_id=0x200 + NODE_ID, is_extended_id=False,
                         data=struct.pack("<ff", 0.25, 0.0))
    end = time.monotonic() + 4.0
    while time.monotonic() < end and not any(e.code == 0x8250 for e in node.emcy.log):
        bus.send(sensor)
        time.sleep(0.01)
    got = [e for e in node.emcy.log if e.code == 0x8250]
    check(bool(got), "EMCY 0x8250 (safe state, leader lost) received"
          + (f": register {got[0].register:#04x}, data {got[0].data.hex()}" if got else ""))
    check(node.sdo.upload(0x1001, 0)[0] & 0x11 == 0x11, "error register 0x1001 has bits 0 and 4")
    count = node.sdo.upload(0x1003, 0)[0]
    field = [struct.unpack("<I", node.sdo.upload(0x1003, k))[0] for k in range(1, count + 1)]
    check(0x8250 in field, "pre-defined error field 0x1003 (newest first): "
          + ", ".join(f"{c:#06x}" for c in field))
    say("EMCY log: " + ", ".join(f"{e.code:#06x}" for e in node.emcy.log))
    # The node's value frame, decoded by the mapping alone: y = x_1 = 0.25 (Q7.16).
    check(tpdo.wait_for_reception(2) is not None, "TPDO1 received")
    y, seq, saturated, absent = (v.raw for v in tpdo.map)
    check(y / 65536 == 0.25 and not saturated and not absent,
          f"TPDO1 decoded: y = {y / 65536}, sequence {seq}")
    # The status PDO, decoded by the mapping alone: safe (2), the leader lost, one entry.
    check(status.wait_for_reception(3) is not None, "TPDO2 (status PDO) received")
    state, lost, boots, overruns, entries = (v.raw for v in status.map)
    check(state == 2 and lost & 1 and entries >= 1,
          f"TPDO2 decoded: state {state}, lost {lost:#x}, boot counter {boots}, "
          f"overruns {overruns}, safe-state entries {entries}")
    # A command frame, decoded by the mapping alone (two REAL32), is the frame's f32 pair; the
    # sensor frame's objects read over SDO hold what the host sent.
    check(command_pdo.wait_for_reception(2) is not None, "TPDO3 (command frame) received")
    q = [v.raw for v in command_pdo.map]
    raw = struct.unpack("<ff", bytes(command_pdo.data))
    check(q == list(raw) and all(v == v for v in q),
          f"TPDO3 decoded: q = {q[0]:.6g}, {q[1]:.6g}")
    x = (real(0x2230, 1), real(0x2230, 2))
    check(x == (0.25, 0.0), f"0x2230 (sensor frame heard) = {x}")
    node.nmt.state = "PRE-OPERATIONAL"
    time.sleep(0.3)

    # Store, restart, restore.
    node.store()
    time.sleep(0.3)
    check(os.path.exists(store), f"0x1010 save wrote {store}")
    stop_node(p)
    p = start_node()
    check(abs(real(zeta) - 0.2) < 1e-7, "after a restart controller.zeta is the stored 0.2")
    node.restore()
    time.sleep(0.3)
    check(abs(real(zeta) - 0.1) < 1e-7, "0x1011 load: controller.zeta back to 0.1")
    check(not os.path.exists(store), "store file removed")
    stop_node(p)
    p = start_node()
    check(abs(real(zeta) - 0.1) < 1e-7, "after another restart controller.zeta is 0.1")
    say("all checks passed")
    finish(0)


if __name__ == "__main__":
    try:
        main()
    except SystemExit:
        raise
    except BaseException as e:  # a timeout or abort the checks did not expect
        print(f"FAIL  {type(e).__name__}: {e}", flush=True)
        for p in procs:
            if p.poll() is None:
                p.kill()
        os._exit(1)
