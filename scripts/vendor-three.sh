#!/usr/bin/env bash
# Vendors three.js from npm into targets/host/assets/three/ for the design report's page
# (targets/host/src/design_page.rs inlines it): the core and the module entry of the pinned
# version, the entry's one import of the core renamed to the bare specifier `three/core` that
# the page's import map resolves (a relative import cannot resolve from a data: URL), and the
# licence. Run it to change the version; the files it writes are committed.
set -euo pipefail
VERSION=0.187.0
cd "$(dirname "$0")/.."
OUT=targets/host/assets/three
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
(cd "$WORK" && npm pack --silent "three@$VERSION" >/dev/null && tar xzf "three-$VERSION.tgz")
mkdir -p "$OUT"
cp "$WORK/package/build/three.core.js" "$OUT/three.core.js"
sed "s#from './three.core.js'#from 'three/core'#g" "$WORK/package/build/three.module.js" > "$OUT/three.module.js"
cp "$WORK/package/LICENSE" "$OUT/LICENSE"
echo "three $VERSION" > "$OUT/VERSION"
if grep -q "three.core.js'" "$OUT/three.module.js" || grep -q "^import .* from '" "$OUT/three.core.js"; then
    echo "vendor-three: an import of a relative path is left; the page cannot resolve it" >&2
    exit 1
fi
echo "vendored three $VERSION into $OUT"
