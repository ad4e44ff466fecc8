# Shared set-up of the side-by-side benchmark scripts (bench/compare.sh,
# bench/optics.sh).  Source it after setting NAME (the script's name in
# messages); it
#   - sets REPS (default 3), W = 1280, H = 720 and ROOT, and cds to ROOT,
#   - installs the peers (bench/install-peers.sh) and builds isoray (release),
#   - sets ISORAY, and TMP (a temporary folder removed on exit),
#   - creates bench/out,
#   - defines add_case NAME SETTINGS COMMAND (into NAMES, SETTINGS, CMDS),
#     now (seconds since the epoch, with nanoseconds), median ARGS, and
#     machine_facts (sets CPU, POV_VER, ISO_VER, REV and DIRTY for reports).
REPS=${REPS:-3}
W=1280
H=720

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"

bench/install-peers.sh
cargo build --release -p isoray

ISORAY=target/release/isoray
[ -x "$ISORAY" ] || { echo "$NAME: $ISORAY not found after build" >&2; exit 1; }

TMP=$(mktemp -d "${TMPDIR:-/tmp}/isoray-$NAME.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
trap 'exit 130' INT TERM          # so that the EXIT trap also cleans up on ^C / kill
mkdir -p bench/out

NAMES=()
SETTINGS=()
CMDS=()
add_case() { NAMES+=("$1"); SETTINGS+=("$2"); CMDS+=("$3"); }

now() { date +%s.%N; }

# median of the arguments (numbers)
median() {
  printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 }
    END { if (NR % 2) printf "%.3f", v[(NR + 1) / 2];
          else printf "%.3f", (v[NR / 2] + v[NR / 2 + 1]) / 2 }'
}

# What the reports say about the machine and the versions.
machine_facts() {
  CPU=$(lscpu | awk -F: '/^Model name/ { sub(/^[ \t]+/, "", $2); print $2; exit }')
  POV_VER=$(povray --version 2>&1 | grep -m1 -o 'POV-Ray [0-9][^ ]*' || echo "POV-Ray ?")
  ISO_VER=$("$ISORAY" --version 2>/dev/null | head -n1 || true)
  REV=$(git rev-parse --short HEAD 2>/dev/null || echo "no commit")
  DIRTY=$(git status --porcelain 2>/dev/null | grep -q . && echo ", uncommitted changes" || true)
}
