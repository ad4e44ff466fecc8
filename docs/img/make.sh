#!/bin/sh
# Regenerates the thumbnails of docs/SCENE.md: renders every scene in
# docs/img/scenes/NAME.toml to docs/img/NAME.png with the release binary.
#
#   docs/img/make.sh             # all thumbnails
#   docs/img/make.sh torus cone  # only these
#
# The binary is target/release/isoray (built if missing); set ISORAY to use another.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bin=${ISORAY:-$root/target/release/isoray}
if [ ! -x "$bin" ]; then
    (cd "$root" && cargo build --release -p isoray)
fi
if [ $# -eq 0 ]; then
    # The example galleries, at thumbnail size.
    for ex in surfaces algebraic; do
        "$bin" render "$root/examples/$ex.toml" -o "$here/$ex.png" --width 640 --height 360 --quiet
        echo "$ex.png"
    done
    set -- $(cd "$here/scenes" && ls *.toml | sed 's/\.toml$//')
fi
for name in "$@"; do
    "$bin" render "$here/scenes/$name.toml" -o "$here/$name.png" --quiet
    echo "$name.png"
done
