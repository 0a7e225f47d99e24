#!/usr/bin/env bash
# The god-object renderer side by side with parry3d on the same meshes (issue 18): builds
# bench/parry (its own crate and lockfile, outside the workspace, so parry3d is compiled only
# here), checks that both find the same closest distances, then prints the timing table of
# docs/rendering.md. Honours CARGO_TARGET_DIR.
set -euo pipefail
cd "$(dirname "$0")/parry"
cargo run --release --locked -q
