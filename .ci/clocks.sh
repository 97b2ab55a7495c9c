#!/usr/bin/env bash
# CI stage "clocks": the clock study of docs/CLOCKS.md. Runs both clock campaigns from a clean
# output directory, checks that their outputs exist, draws the clock figure of one run, then
# checks every figure of docs/CLOCKS.md against what the current code measures (the campaign
# tables and the three 60 s runs of the goal, measured afresh). Needs only the host toolchain.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never
t0=$SECONDS

cargo build --release -p host-sim
built=$SECONDS

for c in clock-drift clock-drift-example2; do
  rm -rf "out/campaigns/$c"
  target/release/host-sim sweep "campaigns/$c.toml" --out "out/campaigns/$c" --quiet
  for f in results.csv summary.csv campaign.json map-1.png map-2.png montecarlo.png; do
    test -s "out/campaigns/$c/$f" || { echo "out/campaigns/$c/$f missing" >&2; exit 1; }
  done
done

rm -rf out/clocks
target/release/host-sim run scenarios/example1-can.toml --out out/clocks -q \
  --set 'clock.drift_ppm=[100, -100, 100, -100]' --set clock.jitter_us=20 --set clock.offset_us=200
for f in summary.json clocks.png clocks.svg; do
  test -s "out/clocks/$f" || { echo "out/clocks/$f missing" >&2; exit 1; }
done

rm -rf target/docs/run/example1-can-clock-*
cargo xtask docs --check --only docs/CLOCKS.md

echo "clocks: build $((built - t0)) s, campaigns, run and documentation check $((SECONDS - built)) s"
