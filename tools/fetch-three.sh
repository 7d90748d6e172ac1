#!/usr/bin/env bash
# Re-make robokit/data/three.min.js (the 3D replay's viewer) and robokit/data/three.LICENSE from the npm registry.
#
# three.js is pinned (THREE_VERSION) and taken from its npm package; npm checks the package against the registry's
# integrity hash. The package ships ES modules only, and a page that opens offline (robokit view) or under a
# script-src 'self' policy (the course server) needs one classic script: esbuild (pinned, ESBUILD_VERSION) bundles
# three.js and its own OrbitControls into one minified file that defines the global THREE.
#
# Usage: tools/fetch-three.sh   (needs node and npm; writes the two files and prints their sizes)
set -euo pipefail
THREE_VERSION=0.187.0
ESBUILD_VERSION=0.28.2
cd "$(dirname "$0")/.."
out="$PWD/robokit/data"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
npm pack --silent "three@$THREE_VERSION" >/dev/null
mkdir -p node_modules/three
tar -xzf "three-$THREE_VERSION.tgz" -C node_modules/three --strip-components=1
cat > entry.js <<'JS'
export * from "three";
export { OrbitControls } from "three/addons/controls/OrbitControls.js";
JS
npx --yes "esbuild@$ESBUILD_VERSION" entry.js --bundle --format=iife --global-name=THREE --minify \
  --legal-comments=none --log-level=warning --outfile=three.min.js \
  "--banner:js=/* three.js $THREE_VERSION (npm: three@$THREE_VERSION, MIT licence: three.LICENSE) and its OrbitControls, bundled by esbuild $ESBUILD_VERSION as one script defining THREE. Made by tools/fetch-three.sh. */"
cp three.min.js "$out/three.min.js"
cp node_modules/three/LICENSE "$out/three.LICENSE"
ls -l "$out/three.min.js" "$out/three.LICENSE"
