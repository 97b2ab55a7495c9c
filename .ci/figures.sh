#!/usr/bin/env bash
# Print figures: a PDF written by `[figures] format = "pdf"` embeds its font (pdffonts from
# poppler-utils reads the PDF as a reader would) and the page is 85 mm wide.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v pdffonts >/dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq poppler-utils >/dev/null
fi
cargo build -q -p host-sim --bin host-sim
out=target/ci-figures
rm -rf "$out"
target/debug/host-sim run scenarios/example1.toml --out "$out" --quiet \
  --set simulation.t_end=2 --set 'figures.format=["pdf"]' --set figures.width_mm=85 \
  --set figures.height_mm=55 --set figures.font_pt=8
target/debug/host-sim graph scenarios/example1.toml --out "$out" --set 'figures.format=["pdf"]' \
  --set figures.width_mm=85
passed=0
failed=0
for f in tracking errors inputs inputs-1 estimates graph; do
  fonts=$(pdffonts "$out/$f.pdf" | tail -n +3)
  width=$(pdfinfo "$out/$f.pdf" | awk '/Page size/ {print $3}')
  if [ -n "$fonts" ] && ! grep -qv ' yes ' <<<"$fonts" && grep -q DejaVuSans <<<"$fonts" \
    && awk -v w="$width" 'BEGIN { exit !(w > 240.5 && w < 241.5) }'; then
    passed=$((passed + 1))
  else
    echo "figures: $f.pdf: fonts not all embedded, or page $width pt wide (85 mm = 240.9 pt)"
    echo "$fonts"
    failed=$((failed + 1))
  fi
done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
