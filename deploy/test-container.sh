#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The container image's test (ctest label `container`; CI runs it in its main stage):
#
#   deploy/test-container.sh --nearpoint build/client/nearpoint
#
# 1. makes the base image localhost/debian-min:bookworm with debootstrap and `podman import`,
#    unless it exists already (the mirror is the one apt uses here);
# 2. builds deploy/Containerfile on it with podman (layers cached between runs; ccache in a build
#    cache mount for the compile), and checks the image: non-root, HEALTHCHECK, ports, size;
# 3. checks that nearpointd in the image refuses 0.0.0.0 without TLS or --insecure (exit 2,
#    naming --listen);
# 4. starts it with --network none, listening on 0.0.0.0 with NEARPOINT_INSECURE=1 and metrics
#    on, preloading the example scene; times container start → health SERVING;
# 5. from a second container in its network namespace (--network container:NAME), runs the
#    image's CLI: `nearpoint health` (SERVING), `nearpoint stream` of the example trajectory
#    (every report checked against this build's `nearpoint distance`, tests/deploy/
#    compare_stream.py), a scrape of /metrics (updates counted, non-zero); the image's own
#    HEALTHCHECK (podman healthcheck run);
# 6. sends SIGTERM while a stream is open: nearpointd drains it and exits 0;
# 7. runs it with TLS (a throw-away CA made with openssl) on 0.0.0.0 without --insecure: the
#    image's HEALTHCHECK turns healthy through NEARPOINT_HEALTH_TLS_CA, plaintext is refused.
#
# Exit 0: passed; 1: failed; 77: skipped, with the reason printed (no podman, podman cannot run
# a container here, or no root for debootstrap) — never a silent pass.
# Environment: CONTAINERS_CONF (default deploy/containers.conf), NEARPOINT_CONTAINER_BASE (a base
# image to use instead; it is never rebuilt), NEARPOINT_CONTAINER_IMAGE (the tag built),
# NEARPOINT_CONTAINER_MIRROR (debootstrap's mirror), JOBS (the image's compile jobs, default 2).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
nearpoint=""
while [ $# -gt 0 ]; do
  case "$1" in
    --nearpoint) nearpoint="$2"; shift 2 ;;
    -h|--help) sed -n '3,28p' "$0"; exit 0 ;;
    *) echo "test-container: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
if [ -z "$nearpoint" ] || [ ! -x "$nearpoint" ]; then
  echo "test-container: --nearpoint BIN (this build's CLI, the reference) is required" >&2
  exit 2
fi

skip() { echo "SKIPPED: $*"; exit 77; }
fail() { echo "FAIL: $*"; failed=1; }
failed=0
step_start=$SECONDS
say() { echo "== [$((SECONDS - step_start)) s] $*"; }

export CONTAINERS_CONF="${CONTAINERS_CONF:-$root/deploy/containers.conf}"
base="${NEARPOINT_CONTAINER_BASE:-localhost/debian-min:bookworm}"
# One tag per checkout, so that two worktrees' runs do not retag each other's image.
image="${NEARPOINT_CONTAINER_IMAGE:-localhost/nearpoint:test-$(printf '%s' "$root" | md5sum | cut -c1-8)}"
server="nearpoint-test-$$"
work="$(mktemp -d)"
cleanup() {
  podman rm -f -t 0 "$server-load" "$server" "$server-tls" >/dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT

# --- can podman run at all? ---
command -v podman >/dev/null || skip "podman is not installed (deploy/install-deps.sh installs it)"
if ! podman info >"$work/info" 2>&1; then
  skip "podman cannot run here: $(tail -n 3 "$work/info" | tr '\n' ' ')"
fi

# --- 1. the base image ---
if podman image exists "$base"; then
  say "base image $base exists (kept; \`podman rmi $base\` makes it again)"
else
  [ "$(id -u)" -eq 0 ] || skip "no base image $base and debootstrap needs root to make one"
  command -v debootstrap >/dev/null || skip "no base image $base and no debootstrap to make one"
  # The mirror apt uses on this machine (deb822 or one-line sources), else Debian's.
  mirror="${NEARPOINT_CONTAINER_MIRROR:-$(
    { cat /etc/apt/sources.list.d/*.sources 2>/dev/null | awk '/^URIs:/ { print $2 }'
      cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null | awk '/^deb / { print $2 }'
    } | awk '!/security/' | head -n 1 || true)}"
  mirror="${mirror:-http://deb.debian.org/debian}"
  say "making $base: debootstrap --variant=minbase bookworm from $mirror"
  rootfs="$work/rootfs"
  if ! debootstrap --variant=minbase bookworm "$rootfs" "$mirror" >"$work/debootstrap.log" 2>&1; then
    tail -n 20 "$work/debootstrap.log"
    echo "FAIL: debootstrap failed (log above)"
    exit 1
  fi
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/*
  tar -C "$rootfs" -c . | podman import --quiet - "$base" >/dev/null
  rm -rf "$rootfs"
  say "made $base"
fi
if ! podman run --rm --network none "$base" true >"$work/run" 2>&1; then
  skip "podman cannot start a container here: $(tail -n 3 "$work/run" | tr '\n' ' ')"
fi

# --- 2. the image ---
# --network host for the build's apt steps only (the Debian mirror); every container below runs
# with --network none or in another container's namespace.
say "podman build -f deploy/Containerfile -t $image (BASE=$base)"
build_start=$SECONDS
previous="$(podman image inspect --format '{{.Id}}' "$image" 2>/dev/null || true)"
# The image's version label: project(nearpoint VERSION ...) in CMakeLists.txt, the one place it is
# written (nearpointd --version prints the same).
version="$(sed -n 's/^project(nearpoint VERSION \([0-9.]*\).*/\1/p' "$root/CMakeLists.txt")"
if ! podman build --format docker --network host --build-arg "BASE=$base" \
       --build-arg "JOBS=${JOBS:-2}" --build-arg "VERSION=$version" -f "$root/deploy/Containerfile" -t "$image" "$root" \
       >"$work/build.log" 2>&1; then
  tail -n 40 "$work/build.log"
  echo "FAIL: the image did not build (log above)"
  exit 1
fi
grep -E 'cache hit|cache miss|Using cache' "$work/build.log" | sort | uniq -c | head -n 8 || true
say "image built in $((SECONDS - build_start)) s"
# The image this tag named before (a source change since): removed, so that CI runs do not pile
# up old images. Its layers that are still build cache stay.
current="$(podman image inspect --format '{{.Id}}' "$image")"
if [ -n "$previous" ] && [ "$previous" != "$current" ]; then
  podman rmi "$previous" >/dev/null 2>&1 || true
fi

size="$(podman image inspect --format '{{.Size}}' "$image")"
user="$(podman image inspect --format '{{.Config.User}}' "$image")"
health="$(podman image inspect --format '{{.Config.Healthcheck}}' "$image")"
ports="$(podman image inspect --format '{{range $p, $v := .Config.ExposedPorts}}{{$p}} {{end}}' "$image")"
echo "image $image: size $size bytes ($((size / 1000000)) MB), user $user, ports $ports"
echo "healthcheck: $health"
[ "$user" = "10001:10001" ] || fail "the image runs as '$user', not the non-root 10001:10001"
[[ "$health" == *nearpoint-healthcheck* ]] ||
  fail "the image has no HEALTHCHECK running nearpoint-healthcheck (built without --format docker?)"
[[ " $ports" == *" 50051/tcp "* && " $ports" == *" 9464/tcp "* ]] ||
  fail "the image does not expose 50051/tcp and 9464/tcp: $ports"
# Only runtime libraries: no compiler, no headers.
if podman run --rm --network none --no-healthcheck --entrypoint /bin/sh "$image" -c \
     'command -v g++ cc cmake >/dev/null || ls /usr/include/grpcpp >/dev/null 2>&1'; then
  fail "the runtime image holds a compiler or -dev headers"
fi

# --- 3. a non-loopback address without TLS or --insecure stops the server ---
set +e
refused="$(podman run --rm --network none --no-healthcheck -e NEARPOINT_LISTEN=0.0.0.0:50051 \
  "$image" 2>&1)"
code=$?
set -e
if [ "$code" -ne 2 ] || [[ "$refused" != *flag=--listen* ]]; then
  fail "NEARPOINT_LISTEN=0.0.0.0:50051 without TLS: expected exit 2 naming --listen, got $code: $refused"
else
  echo "ok   0.0.0.0 without TLS or --insecure refused: $refused"
fi

# --- 4. the server, on 0.0.0.0 inside its own (empty) network namespace ---
# --read-only as in deploy/k8s (readOnlyRootFilesystem). --health-interval disable: the image's
# HEALTHCHECK stays (podman healthcheck run, below) without podman's systemd timer, which a
# machine without systemd cannot make.
share=/usr/local/share/nearpoint
podman create --name "$server" --network none --read-only --health-interval disable \
  -e NEARPOINT_LISTEN=0.0.0.0:50051 -e NEARPOINT_INSECURE=1 \
  -e NEARPOINT_METRICS_LISTEN=0.0.0.0:9464 \
  "$image" --scene "$share/examples/dds_scene.json" --workers 2 --drain-timeout-ms 5000 >/dev/null
start_ns="$(date +%s%N)"
podman start "$server" >/dev/null 2>"$work/start.err" || { cat "$work/start.err"; exit 1; }
serving=""
for _ in $(seq 1 300); do
  if podman exec "$server" nearpoint health --target 127.0.0.1:50051 --timeout-ms 1000 \
       >/dev/null 2>&1; then
    serving="$(date +%s%N)"
    break
  fi
  if [ "$(podman inspect --format '{{.State.Running}}' "$server")" != true ]; then break; fi
done
if [ -z "$serving" ]; then
  podman logs "$server" 2>&1 | tail -n 20
  echo "FAIL: nearpointd in the container never answered SERVING (log above)"
  exit 1
fi
start_ms=$(((serving - start_ns) / 1000000))
echo "start time (podman start -> health SERVING, polled with podman exec): ${start_ms} ms"

# The image's CLI in a second container sharing the server's network namespace.
sidecar() {
  podman run --rm --network "container:$server" --no-healthcheck --entrypoint "$1" "$image" "${@:2}"
}

# --- 5. health, a streamed trajectory, metrics, the HEALTHCHECK ---
say "checks from a second container in the server's network namespace"
if out="$(sidecar nearpoint health --target 127.0.0.1:50051)" && [ "$out" = SERVING ]; then
  echo "ok   nearpoint health: $out"
else
  fail "nearpoint health: '$out'"
fi
if sidecar nearpoint stream dds-demo "$share/examples/dds_trajectory.jsonl" --json \
     --target 127.0.0.1:50051 >"$work/reports.jsonl" 2>"$work/stream.err"; then
  if /usr/bin/python3 "$root/tests/deploy/compare_stream.py" --nearpoint "$nearpoint" \
       --scene "$root/examples/dds_scene.json" --trajectory "$root/examples/dds_trajectory.jsonl" \
       --reports "$work/reports.jsonl"; then
    echo "ok   the streamed trajectory agrees with the local engine"
  else
    fail "the streamed trajectory disagrees with the local engine"
  fi
else
  cat "$work/stream.err"
  fail "nearpoint stream failed"
fi
steps="$(grep -c . "$root/examples/dds_trajectory.jsonl")"
# No curl in the image: bash's /dev/tcp speaks the HTTP/1.0 request.
scrape='exec 3<>/dev/tcp/127.0.0.1/9464 && printf "GET /metrics HTTP/1.0\r\nHost: localhost\r\n\r\n" >&3 && cat <&3'
if sidecar /bin/bash -c "$scrape" >"$work/metrics.txt" 2>&1; then
  updates="$(awk '/^nearpoint_updates_total\{status="ok"\}/ { print $2 }' "$work/metrics.txt")"
  pairs="$(awk '/^nearpoint_pairs_total\{/ { sum += $2 } END { print sum + 0 }' "$work/metrics.txt")"
  echo "metrics: nearpoint_updates_total{status=\"ok\"} ${updates:-absent}, nearpoint_pairs_total (sum) $pairs"
  if [ "${updates:-0}" != "$steps" ] || [ "${pairs%.*}" -le 0 ]; then
    head -n 5 "$work/metrics.txt"
    fail "metrics: expected $steps ok updates and evaluated pairs > 0"
  fi
else
  head -n 5 "$work/metrics.txt"
  fail "the metrics endpoint did not answer"
fi
if out="$(podman healthcheck run "$server" 2>&1)"; then
  echo "ok   the image's HEALTHCHECK: ${out:-healthy}"
else
  fail "podman healthcheck run: $out"
fi

# --- 6. SIGTERM with a stream open: drain, exit 0 ---
say "SIGTERM with an open stream"
podman run --rm --name "$server-load" --network "container:$server" --no-healthcheck \
  --entrypoint nearpoint "$image" load dds-demo "$share/examples/dds_trajectory.jsonl" \
  --streams 1 --duration 30 --target 127.0.0.1:50051 >"$work/load.out" 2>&1 &
load=$!
# Wait until the stream is open (the server's gauge), not a fixed time.
open=""
for _ in $(seq 1 100); do
  if sidecar /bin/bash -c "$scrape" 2>/dev/null | grep -q '^nearpoint_streams_active [1-9]'; then
    open=yes
    break
  fi
done
[ -n "$open" ] || fail "the load stream never showed up in nearpoint_streams_active"
podman kill --signal TERM "$server" >/dev/null
code="$(timeout 60 podman wait "$server" || echo timeout)"
# The load client would keep reconnecting until its 30 s are up: its part is done.
podman rm -f -t 0 "$server-load" >/dev/null 2>&1 || true
wait "$load" || true
podman logs "$server" >"$work/server.log" 2>&1
# The stream was open when the drain began, and the drain finished it.
if [ "$code" = 0 ] && grep -q 'event=signal.*SIGTERM' "$work/server.log" &&
   grep -q 'event=shutdown_begin open_streams=1' "$work/server.log" &&
   grep -q 'event=shutdown_complete drained=all' "$work/server.log"; then
  echo "ok   SIGTERM: drained and exited 0 ($(grep -o 'event=shutdown_complete.*' "$work/server.log" | head -c 200))"
else
  tail -n 15 "$work/server.log"
  fail "SIGTERM: exit status $code (expected 0 after a drain of the open stream)"
fi

# --- 7. TLS: the documented configuration for a published port, and its HEALTHCHECK ---
# A throw-away CA and a server certificate for localhost (what nearpoint-healthcheck dials).
if command -v openssl >/dev/null; then
  say "TLS: NEARPOINT_TLS_CERT/KEY, the HEALTHCHECK through NEARPOINT_HEALTH_TLS_CA"
  tls="$work/tls"
  mkdir -p "$tls"
  ec=(-newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes)
  openssl req -x509 "${ec[@]}" -keyout "$tls/ca.key" -out "$tls/ca.pem" -days 2 \
    -subj /CN=nearpoint-test-ca >/dev/null 2>&1
  openssl req "${ec[@]}" -keyout "$tls/server.key" -out "$tls/server.csr" \
    -subj /CN=localhost >/dev/null 2>&1
  printf 'subjectAltName=DNS:localhost,IP:127.0.0.1\n' >"$tls/san"
  openssl x509 -req -in "$tls/server.csr" -CA "$tls/ca.pem" -CAkey "$tls/ca.key" \
    -CAcreateserial -out "$tls/server.pem" -days 2 -extfile "$tls/san" >/dev/null 2>&1
  # Readable by the image's user (uid 10001); a throw-away key in a temporary directory.
  chmod 755 "$work" "$tls" && chmod 644 "$tls"/*
  d=/etc/nearpoint/tls
  podman run -d --name "$server-tls" --network none --read-only --health-interval disable \
    -v "$tls:$d:ro" -e NEARPOINT_LISTEN=0.0.0.0:50051 \
    -e NEARPOINT_TLS_CERT="$d/server.pem" -e NEARPOINT_TLS_KEY="$d/server.key" \
    -e NEARPOINT_HEALTH_TLS_CA="$d/ca.pem" "$image" >/dev/null 2>"$work/start-tls.err" ||
    cat "$work/start-tls.err"
  healthy=""
  for _ in $(seq 1 100); do
    if podman healthcheck run "$server-tls" >/dev/null 2>&1; then healthy=yes; break; fi
    if [ "$(podman inspect --format '{{.State.Running}}' "$server-tls")" != true ]; then break; fi
  done
  if [ -n "$healthy" ]; then
    echo "ok   TLS on 0.0.0.0 without --insecure: the HEALTHCHECK is healthy"
  else
    podman logs "$server-tls" 2>&1 | tail -n 5
    fail "TLS: the HEALTHCHECK never turned healthy"
  fi
  if out="$(podman run --rm --network "container:$server-tls" --no-healthcheck \
              --entrypoint nearpoint "$image" health --target 127.0.0.1:50051 \
              --timeout-ms 2000 2>&1)"; then
    fail "TLS: a plaintext health check was answered: $out"
  else
    echo "ok   TLS: plaintext to the TLS port is refused"
  fi
  podman stop -t 20 "$server-tls" >/dev/null 2>&1 || true
  code="$(podman inspect --format '{{.State.ExitCode}}' "$server-tls")"
  [ "$code" = 0 ] || fail "TLS: nearpointd exited $code on podman stop"
else
  echo "not checked: TLS in the image (no openssl here to make a throw-away CA)"
fi

say "done"
if [ "$failed" -ne 0 ]; then
  echo "test-container: FAILED"
  exit 1
fi
echo "test-container: passed (image $((size / 1000000)) MB, start to SERVING ${start_ms} ms)"
