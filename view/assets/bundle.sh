#!/usr/bin/env bash
# Rebuilds three.min.js, the part of three.js the animation page inlines, from the npm
# packages: three (the renderer, MIT) and esbuild (the bundler). Needs Node.js and npm; the
# page's users and CI need neither (the bundle is committed). Usage: bash view/assets/bundle.sh
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cd "$work"
npm init -y >/dev/null
npm install --no-audit --no-fund three@0.187.0 esbuild@0.28.2 >/dev/null
cp "$here/entry.js" .
npx esbuild entry.js --bundle --minify --format=iife --target=es2020 \
  --legal-comments=none --outfile=three.min.js
{
  echo "/* three.js $(node -p "JSON.parse(require('fs').readFileSync('node_modules/three/package.json')).version") (https://threejs.org), MIT licence: view/assets/THREE_LICENSE. Bundled by view/assets/bundle.sh. */"
  cat three.min.js
} > "$here/three.min.js"
cp node_modules/three/LICENSE "$here/THREE_LICENSE"
wc -c "$here/three.min.js"
