#!/usr/bin/env bash
# Clean release build time of each backend alone (dependencies already downloaded:
# run `cargo fetch` first). Each build uses its own fresh target dir under target/buildtime/.
# GMP_MPFR_SYS_CACHE=_ disables gmp-mpfr-sys's cache of the compiled GMP in ~/.cache, so the
# rug number is a true from-scratch build of the bundled GMP.
set -eu
cd "$(dirname "$0")"
cargo fetch -q
for f in none num dashu malachite rug; do
  dir=target/buildtime/$f
  rm -rf "$dir"
  feats=$([ "$f" = none ] && echo "" || echo "--features $f")
  start=$(date +%s.%N)
  GMP_MPFR_SYS_CACHE=_ CARGO_TARGET_DIR=$dir cargo build -q --release --no-default-features $feats
  end=$(date +%s.%N)
  printf '%-10s %6.1f s   (loadavg now: %s)\n' "$f" "$(echo "$end - $start" | bc)" "$(cut -d' ' -f1-3 /proc/loadavg)"
done
