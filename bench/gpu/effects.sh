# The Unity thesis's four effect sets (its Tests 1-4) for
# examples/realtime/primitives.toml, as arguments of `isoray render` (and of
# the frames example). Source this file; `effect_args N` prints set N's flags.
NOSPEC=""
for m in sphere box cylinder floor torus prism; do
  NOSPEC="$NOSPEC --set material.$m.specular=[0,0,0]"
done
effect_args() {
  case "$1" in
    1) echo "" ;;                                                            # soft shadows, AO, specular
    2) echo "$NOSPEC" ;;                                                     # no specular
    3) echo "$NOSPEC --set render.ao=false" ;;                               # no AO, no specular
    4) echo "$NOSPEC --set render.ao=false --set render.shadows=none" ;;     # nothing
  esac
}
