"""python-can's `slcan` interface talking to the node firmware on QEMU, as a CANable / USBtin
adapter user would: the UART is exposed as a TCP socket, python-can opens it (`C`, `S8`, `O`,
answered by the node), receives the node's Boot frame, sends an (empty, hence invalid)
configuration and must receive the
node's REJECTED frame (29-bit id 0x00010013, reason 1 = word count), which docs/wire.dbc
decodes as the message Rejected.
Usage: slcan_node.py <node-fw ELF> <wire.dbc>"""
import socket
import struct
import subprocess
import sys
import time

import can
import cantools


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main():
    port = free_port()
    qemu = subprocess.Popen(
        ["qemu-system-arm", "-M", "mps2-an386", "-cpu", "cortex-m4", "-nographic",
         "-monitor", "none", "-serial", f"tcp:127.0.0.1:{port},server=on,wait=on",
         "-icount", "shift=0", "-kernel", sys.argv[1]],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.time() + 20
        while True:
            try:
                bus = can.Bus(interface="slcan", channel=f"socket://127.0.0.1:{port}",
                              bitrate=1_000_000)
                break
            except Exception:
                if time.time() > deadline or qemu.poll() is not None:
                    raise
                time.sleep(0.2)
        db = cantools.database.load_file(sys.argv[2])
        boot = bus.recv(timeout=10)
        if boot is None or boot.arbitration_id != db.get_message_by_name("Boot").frame_id:
            sys.exit(f"expected the node's Boot frame first, got {boot}")
        bus.send(can.Message(arbitration_id=0x00010011, is_extended_id=True,
                             data=struct.pack("<H", 5)))
        m = bus.recv(timeout=10)
        bus.shutdown()
        if m is None or m.arbitration_id != 0x00010013 or not m.is_extended_id or list(m.data) != [1]:
            sys.exit(f"expected REJECTED(1) from the node, got {m}")
        decoded = db.get_message_by_name("Rejected")
        if decoded.frame_id != m.arbitration_id or decoded.decode(bytes(m.data)) != {"code": 1}:
            sys.exit(f"docs/wire.dbc does not decode {m} as Rejected(code 1)")
        print(f"node answered over SLCAN: {m}, decoded as Rejected(code 1)")
    finally:
        qemu.kill()
        qemu.wait()


if __name__ == "__main__":
    main()
