#!/usr/bin/env bash
# Carry an unfinished run to the next session (a new machine starts with an empty runs/):
#   carry.sh save RUN DEST   copies RUN without checkpoints into DEST/<run>, plus its latest model
#                            (checkpoints/<latest>/model.zip + state.json, about 8 MB; the replay,
#                            3 GB at 5e4 transitions, stays behind)
#   carry.sh restore DEST/<run> OUT   copies it back into OUT/<run>, ready for `relmogen train --resume`;
#                            the resumed run starts with an empty replay: it collects the preset's
#                            learning_starts transitions (random actions, as a new run does) before it
#                            learns again, then refills it at its current epsilon (resumes.jsonl says so)
set -euo pipefail
case $1 in
  save)
    RUN=${2%/}; DEST=$3; name=$(basename "$RUN"); latest=$(cat "$RUN/checkpoints/latest")
    mkdir -p "$DEST/$name/checkpoints/$latest"
    (cd "$RUN" && tar cf - --exclude=./checkpoints .) | (cd "$DEST/$name" && tar xf -)
    cp "$RUN/checkpoints/$latest/model.zip" "$RUN/checkpoints/$latest/state.json" "$DEST/$name/checkpoints/$latest/"
    echo "$latest" > "$DEST/$name/checkpoints/latest"
    echo "saved $RUN at $latest into $DEST/$name" ;;
  restore)
    SRC=${2%/}; OUT=$3; mkdir -p "$OUT"
    if [ -e "$OUT/$(basename "$SRC")" ]; then echo "$OUT/$(basename "$SRC") exists: resume it instead" >&2; exit 1; fi
    cp -r "$SRC" "$OUT/"
    echo "restored into $OUT/$(basename "$SRC"); relmogen train --resume $OUT/$(basename "$SRC") --quiet" ;;
  *) echo "usage: carry.sh save RUN DEST | carry.sh restore DEST/RUN OUT" >&2; exit 2 ;;
esac
