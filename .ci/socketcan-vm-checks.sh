#!/bin/sh
# The runs of `kind = "socketcan"` that need CAN sockets, and the checks that need the guest's
# processes; run inside the test VM by .ci/socketcan.sh: `cargo xtask vm [--can 5] -- sh
# .ci/socketcan-vm-checks.sh <check>…`. The summaries they write under target/socketcan-ci/ are
# judged on the host afterwards (.ci/socketcan-judge.py): Python starts slowly in the emulated
# guest. Needs target/release/{host-sim,node-linux}. SC_SET="--set key=value …" is passed to every
# run (e.g. a time scale).
#
#   vcan-example1   Example 1 over vcan0, four node processes, with a trace: no node process
#                   left, vcan0 as found (error against kind = "can", late frames: judged on
#                   the host)
#   vcan-fd         Example 1 over vcan0 in CAN FD mode (MTU 72) with the bench's frame set
#                   (network.data_bitrate = 4 Mbit/s, packed sensor frames) for 2 s, with a
#                   trace: exit 0, every frame CAN FD with bit-rate switching, the trace's
#                   stamps never step back and none is 0, one leader frame per sample; vcan0 back
#                   to MTU 16 (its load per sample is measured on the host: cargo xtask
#                   trace-load)
#   kill-node       agent 3's node killed mid-run: host-sim reports the agent lost within
#                   node_timeout and exits 3 after writing its outputs (summary state "lost", the
#                   plant applied network.lost_command = "zero"), agent 4 (which hears 3) reports
#                   the link stale, no process left
#   exit-statuses   node-linux: an agent outside the identifier plan is exit 2 naming node.agent,
#                   no sensor frame within node.start_timeout is exit 3; host-sim: a node that
#                   never comes is exit 3, monitor on a missing interface or DBC is exit 2
#   kill-host       host-sim killed mid-run: every node stops within its host timeout
#   sja1000         Example 1 over emulated Kvaser PCI SJA1000 controllers (host can0, node i
#                   on can<i>) for 6 s, past 2 Ts = 4 s, which keeps this check within 3
#                   minutes with boot: bitrates and error counters read; a node's controller set to
#                   another bitrate, what the bus does reported
set -u
HS=target/release/host-sim
OUT=target/socketcan-ci
for d in vcan vcan-fd kill-node kill-host exit-statuses sja1000 sja1000-bitrate; do mkdir -p "$OUT/$d"; done
failed=0
fail() { echo "FAIL [$check]: $*"; failed=1; }
ok() { echo "ok   [$check]: $*"; }

# Node processes still alive (names from /proc; the chroot has no procps for sure).
nodes_alive() {
  n=0
  for c in /proc/[0-9]*/comm; do
    [ "$(cat "$c" 2>/dev/null)" = node-linux ] && n=$((n + 1))
  done
  echo "$n"
}

# The pid of the node of agent $1.
node_pid() {
  for d in /proc/[0-9]*; do
    if [ "$(cat "$d/comm" 2>/dev/null)" = node-linux ] &&
      tr '\0' ' ' <"$d/cmdline" 2>/dev/null | grep -q "agent-$1.toml"; then
      basename "$d"
      return
    fi
  done
}

no_process_left() {
  sleep 0.5
  left=$(nodes_alive)
  [ "$left" = 0 ] && ok "no node process left" || fail "$left node processes left"
}

vcan_example1() {
  before=$(ip -details link show vcan0)
  t0=$(date +%s)
  # shellcheck disable=SC2086
  $HS run scenarios/example1-socketcan.toml --out "$OUT/vcan" --trace "$OUT/vcan/vcan0.log" \
    ${SC_SET:-} 2>"$OUT/vcan/stderr.log"
  rc=$?
  echo "run: exit $rc, $(($(date +%s) - t0)) s wall"
  grep -v "^node-linux INFO" "$OUT/vcan/stderr.log" | tail -n 5
  [ $rc = 0 ] || fail "host-sim exited with $rc"
  n=$(grep -c "the host commanded the end of the run" "$OUT/vcan/stderr.log")
  g=$(grep -c "host is gone" "$OUT/vcan/stderr.log")
  [ "$n" = 4 ] && [ "$g" = 0 ] && ok "the run ended with a stop command to all 4 nodes, no error" ||
    fail "$n of 4 nodes got the stop command, $g said the host is gone"
  no_process_left
  [ "$(ip -details link show vcan0)" = "$before" ] && ok "vcan0 as found" || fail "vcan0 changed"
}

# Stamps that step back, stamps of 0, leader frames (101), CAN FD lines with BRS, classical
# lines of a candump log.
trace_figures() {
  awk '{ t = substr($1, 2, length($1) - 2) + 0; if (NR > 1 && t < p) back++; if (t == 0) zero++; p = t
         split($3, f, "#"); if (f[1] == "101") leader++
         if (index($3, "##1") > 0) fd++; else if (index($3, "##") == 0) classic++ }
       END { printf "%d %d %d %d %d\n", back, zero, leader, fd, classic }' "$1"
}

vcan_fd() {
  ip link set vcan0 down && ip link set vcan0 mtu 72 && ip link set vcan0 up
  # shellcheck disable=SC2086
  $HS run scenarios/example1-socketcan.toml --out "$OUT/vcan-fd" --trace "$OUT/vcan-fd/vcan0.log" \
    --set simulation.t_end=2 --set network.data_bitrate=4000000 \
    --set 'network.sensor_frames="packed"' ${SC_SET:-} 2>"$OUT/vcan-fd/stderr.log"
  rc=$?
  ip link set vcan0 down && ip link set vcan0 mtu 16 && ip link set vcan0 up
  grep -v "^node-linux INFO" "$OUT/vcan-fd/stderr.log" | tail -n 3
  [ $rc = 0 ] && ok "Example 1 ran on CAN FD with packed sensor frames" || fail "host-sim exited with $rc"
  set -- $(trace_figures "$OUT/vcan-fd/vcan0.log")
  echo "trace: $1 stamps back, $2 stamps 0, $3 leader frames, $4 FD+BRS lines, $5 classical lines"
  [ "$1" = 0 ] && [ "$2" = 0 ] && ok "trace stamps monotonic, none 0" || fail "trace stamps: $1 back, $2 zero"
  [ "$3" -ge 2000 ] && ok "trace complete: $3 leader frames for 2000 samples" ||
    fail "trace incomplete: $3 leader frames for 2000 samples"
  [ "$5" = 0 ] && [ "$4" -gt 0 ] && ok "every frame CAN FD with bit-rate switching" ||
    fail "$5 classical frames on a CAN FD bench"
  no_process_left
}

kill_node() {
  # Agent 3's node is killed; agent 4 hears agent 3 (Example 1: neighbours [[], [1], [1], [1, 3]]).
  # shellcheck disable=SC2086
  $HS run scenarios/example1-socketcan.toml --out "$OUT/kill-node" --set simulation.t_end=3 \
    ${SC_SET:-} 2>"$OUT/kill-node/stderr.log" &
  hs=$!
  while ! grep -q "agent 3: first sensor frame" "$OUT/kill-node/stderr.log" 2>/dev/null; do
    kill -0 $hs 2>/dev/null || break
    sleep 0.1
  done
  sleep 1
  kill -9 "$(node_pid 3)"
  wait $hs
  rc=$?
  echo "run: exit $rc"
  [ $rc = 3 ] && ok "a run with a lost node exits 3" || fail "a run with a lost node exited $rc"
  grep -q "bench: agent 3 lost at t = " "$OUT/kill-node/stderr.log" &&
    ok "the exit names agent 3 lost" || fail "the exit does not name the lost agent"
  grep -E "agent 3 lost|neighbour 3" "$OUT/kill-node/stderr.log" | head -n 4
  grep -q "agent 3 lost (no command for" "$OUT/kill-node/stderr.log" &&
    ok "host-sim reports agent 3 lost once silent for node_timeout" || fail "loss not reported"
  grep -q "agent 4: neighbour 3 stale" "$OUT/kill-node/stderr.log" &&
    ok "agent 4 reports its link to agent 3 stale" || fail "agent 4 did not report the link stale"
  no_process_left
}

kill_host() {
  # shellcheck disable=SC2086
  $HS run scenarios/example1-socketcan.toml --out "$OUT/kill-host" ${SC_SET:-} \
    2>"$OUT/kill-host/stderr.log" &
  hs=$!
  while ! grep -q "first sensor frame" "$OUT/kill-host/stderr.log" 2>/dev/null; do sleep 0.1; done
  sleep 1
  kill -9 $hs
  t=$(date +%s)
  wait $hs 2>/dev/null
  while [ "$(nodes_alive)" != 0 ] && [ $(($(date +%s) - t)) -lt 5 ]; do sleep 0.1; done
  grep "host is gone\|stopped" "$OUT/kill-host/stderr.log" | head -n 8
  n=$(grep -c "the host is gone" "$OUT/kill-host/stderr.log")
  [ "$n" = 4 ] && ok "all 4 nodes saw the host go" || fail "$n of 4 nodes saw the host go"
  no_process_left
}

exit_statuses() {
  d="$OUT/exit-statuses"
  # host-sim waiting for external nodes that never come: exit 3 (the node files stay in $d).
  $HS run scenarios/example1-socketcan.toml --out "$d/run" --set 'network.nodes="external"' \
    --set network.start_timeout=1 --set "network.node_dir=\"$d\"" 2>"$d/run.log"
  rc=$?
  [ $rc = 3 ] && grep -q "bench: no node of agent" "$d/run.log" && ok "host-sim: missing nodes are exit 3" ||
    fail "host-sim with missing nodes exited $rc: $(cat "$d/run.log")"
  # A node file whose agent lies outside its identifier plan: exit 2 before any socket.
  sed 's/^agent = 1$/agent = 9/' "$d/agent-1.toml" >"$d/outside.toml"
  target/release/node-linux "$d/outside.toml" 2>"$d/outside.log"
  rc=$?
  [ $rc = 2 ] && grep -q "node.agent" "$d/outside.log" &&
    ok "node-linux: agent outside the plan is exit 2 naming node.agent" ||
    fail "node-linux: agent outside the plan exited $rc: $(cat "$d/outside.log")"
  # No host: the node gives up after node.start_timeout (1 s here) with exit 3.
  sed 's/^start_timeout = .*$/start_timeout = 1.0/' "$d/agent-1.toml" >"$d/lonely.toml"
  target/release/node-linux "$d/lonely.toml" 2>"$d/lonely.log"
  rc=$?
  [ $rc = 3 ] && grep -q "node.start_timeout" "$d/lonely.log" &&
    ok "node-linux: never started is exit 3 after node.start_timeout" ||
    fail "node-linux without a host exited $rc: $(tail -n 2 "$d/lonely.log")"
  $HS monitor nope0 --once 2>"$d/monitor.log"
  rc=$?
  [ $rc = 2 ] && ok "monitor on a missing interface is exit 2" || fail "monitor on a missing interface exited $rc"
  $HS monitor vcan0 --once --dbc "$d/none.dbc" 2>>"$d/monitor.log"
  rc=$?
  [ $rc = 2 ] && ok "monitor with a missing DBC is exit 2" || fail "monitor with a missing DBC exited $rc"
}

sja1000() {
  for i in 0 1 2 3 4; do
    echo "can$i: $(ip -details link show can$i | grep -Eo 'bitrate [0-9]+' | head -n 1)"
  done
  # shellcheck disable=SC2086
  $HS run scenarios/example1-socketcan.toml --out "$OUT/sja1000" --set simulation.t_end=6 ${SC_SET:-} \
    --set 'network.interface="can0"' \
    --set 'network.node_interfaces=["can1","can2","can3","can4"]' 2>"$OUT/sja1000/stderr.log"
  rc=$?
  grep -v "^node-linux INFO" "$OUT/sja1000/stderr.log" | tail -n 3
  [ $rc = 0 ] && ok "Example 1 ran over the SJA1000 controllers" || fail "host-sim exited with $rc"
  for i in 0 1 2 3 4; do
    echo "can$i: $(ip -details -statistics link show can$i | grep -Eo 'can state [A-Z-]+ \(berr-counter tx [0-9]+ rx [0-9]+\)')"
  done
  # A controller at another bitrate: on a real bus its frames are errors and it goes error-passive
  # or bus-off; QEMU's CAN bus carries frames whatever the bit timing: this shows what it does.
  ip link set can4 down
  ip link set can4 type can bitrate 125000 restart-ms 100
  ip link set can4 up
  echo "can4: $(ip -details link show can4 | grep -Eo 'bitrate [0-9]+' | head -n 1)"
  # shellcheck disable=SC2086
  $HS run scenarios/example1-socketcan.toml --out "$OUT/sja1000-bitrate" --set simulation.t_end=2 \
    ${SC_SET:-} --set 'network.interface="can0"' \
    --set 'network.node_interfaces=["can1","can2","can3","can4"]' 2>"$OUT/sja1000-bitrate/stderr.log"
  echo "run with can4 at 125 kbit/s: exit $?"
  for i in 0 4; do
    echo "can$i: $(ip -details -statistics link show can$i | grep -Eo 'can state [A-Z-]+ \(berr-counter tx [0-9]+ rx [0-9]+\)')"
    echo "can$i restarts, bus-errors, arbitration-lost, error-warning, error-passive, bus-off: $(ip -details -statistics link show can$i | grep -A1 're-started' | tail -n 1 | awk '{print $1, $2, $3, $4, $5, $6}')"
  done
  ok "bitrates set and error counters read"
  no_process_left
}

for check in "$@"; do
  echo "== $check"
  case $check in
  vcan-example1) vcan_example1 ;;
  vcan-fd) vcan_fd ;;
  kill-node) kill_node ;;
  exit-statuses) exit_statuses ;;
  kill-host) kill_host ;;
  sja1000) sja1000 ;;
  *) fail "unknown check" ;;
  esac
done
exit $failed
