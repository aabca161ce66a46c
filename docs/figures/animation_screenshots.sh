#!/usr/bin/env bash
# Regenerates the animation screenshots of docs/scenes.md: the default scene and the
# slider-crank with a flywheel, each as `lieflow run --animate` writes it, shown by headless
# Chromium (Debian's package `chromium`) at a frame partway through the run.
#   bash docs/figures/animation_screenshots.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -p lieflow-cli
mkdir -p target/animations
shoot() { # scene-or-empty, name, frame
  local page="target/animations/$2.html"
  target/release/lieflow run $1 --animate "$page" >/dev/null
  chromium --headless --no-sandbox --disable-gpu --enable-unsafe-swiftshader --disable-quic \
    --no-first-run --disable-background-networking --disable-component-update --disable-sync \
    --hide-scrollbars --user-data-dir="$(mktemp -d)" --window-size=1200,700 \
    --virtual-time-budget=4000 --screenshot="docs/figures/animation_$2.png" \
    "file://$PWD/$page#frame=$3" 2>/dev/null
  echo "docs/figures/animation_$2.png ($page)"
}
shoot "" default 310
shoot scenes/slider_crank.toml slider_crank 120
