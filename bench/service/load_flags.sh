# SPDX-License-Identifier: Apache-2.0
# Sourced by capacity.sh and profile.sh: the `nearpoint load` flags that the environment chooses.
#   BATCH   pose sets per message (default 1: StreamPoses; more: StreamPoseBatches)
#   WINDOW  updates in flight per stream (default 4; with BATCH > 1 two batches)
# Sets the array load_flags (the same for `nearpoint load` and `nearpoint dds load`), and batch
# and window. Unbatched it passes no --batch, so that an older build's nearpoint can be measured
# with the same scripts.
batch="${BATCH:-1}"
if [ "$batch" -gt 1 ]; then
  window="${WINDOW:-$((2 * batch))}"
  load_flags=(--window "$window" --batch "$batch")
else
  window="${WINDOW:-4}"
  load_flags=(--window "$window")
fi
