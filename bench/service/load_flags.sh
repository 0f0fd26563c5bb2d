# SPDX-License-Identifier: Apache-2.0
# Sourced by capacity.sh and profile.sh: the `nearpoint load` flags that the environment chooses.
#   BATCH   pose sets per message (default 1: StreamPoses; more: StreamPoseBatches)
#   WINDOW  updates in flight per stream (default 4; with BATCH > 1 two batches)
# Sets the array load_flags. Unbatched it passes no --batch, so that an older build's nearpoint
# can be measured with the same scripts.
batch="${BATCH:-1}"
if [ "$batch" -gt 1 ]; then
  load_flags=(--window "${WINDOW:-$((2 * batch))}" --batch "$batch")
else
  load_flags=(--window "${WINDOW:-4}")
fi
