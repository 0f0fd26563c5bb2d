#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""nearpointd's TLS, mutual TLS and bearer token (issue 23, item 3), against real nearpointd
processes on 127.0.0.1:0, with a throw-away CA and certificates made here with openssl.

    check_tls.py CASE --nearpointd build/server/nearpointd --nearpoint build/client/nearpoint \
        --pythonpath build/client/python

CASE is one of
  bad-config  flags that must stop nearpointd at start (exit 2, a message naming the flag, never
              listening): missing or unreadable certificate, key, client CA or token file
              (also through $NEARPOINT_TOKEN_FILE), a token without TLS, a non-loopback --listen
              without TLS or --insecure (checked before binding: nothing binds there); and a key
              that does not match the certificate (exit 2 as well: configuration).
  tls         TLS with a token: the Python client and the CLI (the C++ client) with the right
              token succeed; a wrong or missing token is UNAUTHENTICATED; the health service
              answers without a token; plaintext to the TLS port, and a client that does not trust
              the server's CA, fail; the token never appears in the server's log.
              `nearpoint health` (exit 0 when SERVING) over TLS without a token, and against a
              plaintext server: the whole server, one service, an unknown service, no server.
  mtls        mutual TLS: a client certificate from the CA is accepted (Python and CLI); none, or
              one from another CA, is refused.
Every server is stopped with SIGTERM and must exit 0; the servers die with this process.
"""
import argparse
import ctypes
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

ARGS = None
FAILURES = []


def check(condition, what):
    print(("ok   " if condition else "FAIL ") + what, flush=True)
    if not condition:
        FAILURES.append(what)


def die_with_parent():
    PR_SET_PDEATHSIG = 1
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


def openssl(*args, cwd):
    subprocess.run(["openssl", *args], cwd=cwd, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, timeout=60)


def make_pki(d):
    """ca.pem signs server.pem (localhost, 127.0.0.1) and client.pem; other-ca.pem signs
    other-client.pem. EC P-256 keys: quick to make."""
    def key(name):
        openssl("genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:P-256",
                "-out", f"{name}.key", cwd=d)

    def ca(name):
        key(name)
        openssl("req", "-x509", "-new", "-key", f"{name}.key", "-subj", f"/CN=nearpoint test {name}",
                "-days", "2", "-out", f"{name}.pem", cwd=d)

    def leaf(name, signer, cn, ext):
        key(name)
        openssl("req", "-new", "-key", f"{name}.key", "-subj", f"/CN={cn}", "-out", f"{name}.csr",
                cwd=d)
        with open(os.path.join(d, f"{name}.ext"), "w", encoding="ascii") as f:
            f.write(ext)
        openssl("x509", "-req", "-in", f"{name}.csr", "-CA", f"{signer}.pem", "-CAkey",
                f"{signer}.key", "-CAcreateserial", "-days", "2", "-extfile", f"{name}.ext",
                "-out", f"{name}.pem", cwd=d)

    ca("ca")
    ca("other-ca")
    leaf("server", "ca", "localhost",
         "subjectAltName=DNS:localhost,IP:127.0.0.1\nextendedKeyUsage=serverAuth\n")
    leaf("client", "ca", "nearpoint-client", "extendedKeyUsage=clientAuth\n")
    leaf("other-client", "other-ca", "intruder", "extendedKeyUsage=clientAuth\n")
    with open(os.path.join(d, "token"), "w", encoding="ascii") as f:
        f.write("s3cr3t-token-0123456789abcdef\n")
    with open(os.path.join(d, "wrong-token"), "w", encoding="ascii") as f:
        f.write("s3cr3t-token-0123456789abcdeX\n")
    with open(os.path.join(d, "scene.json"), "w", encoding="ascii") as f:
        json.dump({"id": "tls-scene",
                   "geometries": {"cube": {"box": [0.5, 0.5, 0.5]}},
                   "objects": [{"id": "a", "geometry": "cube"},
                               {"id": "b", "geometry": "cube",
                                "pose": {"translation": [3, 0, 0]}}]}, f)


class Server:
    """nearpointd on 127.0.0.1:0 with the given extra flags; stderr kept for the checks."""

    def __init__(self, d, *flags, env=None):
        self.port_file = os.path.join(d, f"port-{time.monotonic_ns()}")
        self.log = tempfile.TemporaryFile(dir=d)
        self.process = subprocess.Popen(
            [ARGS.nearpointd, "--listen", "127.0.0.1:0", "--port-file", self.port_file,
             "--workers", "1", *flags],
            stdout=subprocess.DEVNULL, stderr=self.log,
            env=env or {k: v for k, v in os.environ.items() if not k.startswith("NEARPOINT_")},
            preexec_fn=die_with_parent)
        deadline = time.monotonic() + 20
        while not os.path.exists(self.port_file):
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"nearpointd did not start:\n{self.stderr()}")
            time.sleep(0.05)
        with open(self.port_file, encoding="ascii") as f:
            self.target = f"127.0.0.1:{int(f.read().strip())}"
        self.localhost = self.target.replace("127.0.0.1", "localhost")

    def stderr(self):
        self.log.seek(0)
        return self.log.read().decode("utf-8", errors="replace")

    def stop(self):
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        return self.process.returncode


def run_start_failure(d, flags, env_extra=None, listen="127.0.0.1:0"):
    env = {k: v for k, v in os.environ.items() if not k.startswith("NEARPOINT_")}
    env.update(env_extra or {})
    listen_flag = ["--listen", listen] if listen else []  # None: from the environment
    result = subprocess.run([ARGS.nearpointd, *listen_flag, "--workers", "1", *flags],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, timeout=30,
                            preexec_fn=die_with_parent)
    return result.returncode, result.stderr.decode("utf-8", errors="replace")


def case_bad_config(d):
    p = lambda name: os.path.join(d, name)  # noqa: E731
    missing = p("does-not-exist.pem")
    unreadable = p("unreadable-dir")  # a directory: open() works, reading fails
    os.makedirs(unreadable, exist_ok=True)
    not_pem = p("token")
    tls = ["--tls-cert", p("server.pem"), "--tls-key", p("server.key")]
    cases = [
        ("missing certificate", ["--tls-cert", missing, "--tls-key", p("server.key")], None,
         "127.0.0.1:0", "--tls-cert"),
        ("certificate not PEM", ["--tls-cert", not_pem, "--tls-key", p("server.key")], None,
         "127.0.0.1:0", "--tls-cert"),
        ("missing key", ["--tls-cert", p("server.pem"), "--tls-key", missing], None,
         "127.0.0.1:0", "--tls-key"),
        ("certificate without key", ["--tls-cert", p("server.pem")], None, "127.0.0.1:0",
         "--tls-key"),
        ("key without certificate", ["--tls-key", p("server.key")], None, "127.0.0.1:0",
         "--tls-cert"),
        ("missing client CA", tls + ["--tls-client-ca", missing], None, "127.0.0.1:0",
         "--tls-client-ca"),
        ("client CA without TLS", ["--tls-client-ca", p("ca.pem")], None, "127.0.0.1:0",
         "--tls-client-ca"),
        ("missing token file", tls + ["--token-file", missing], None, "127.0.0.1:0",
         "--token-file"),
        ("unreadable token file", tls + ["--token-file", unreadable], None, "127.0.0.1:0",
         "--token-file"),
        ("unreadable token file from the environment", tls,
         {"NEARPOINT_TOKEN_FILE": missing}, "127.0.0.1:0", "--token-file"),
        ("token without TLS", ["--token-file", p("token")], None, "127.0.0.1:0",
         "--token-file"),
        # Checked before binding: these never reach the network.
        ("0.0.0.0 without TLS", [], None, "0.0.0.0:0", "--listen"),
        ("0.0.0.0 from $NEARPOINT_LISTEN without TLS", [], {"NEARPOINT_LISTEN": "0.0.0.0:0"},
         None, "--listen"),
        ("missing certificate from $NEARPOINT_TLS_CERT", ["--tls-key", p("server.key")],
         {"NEARPOINT_TLS_CERT": missing}, "127.0.0.1:0", "--tls-cert"),
        # NEARPOINT_INSECURE=1 acknowledges (deploy/test-container.sh serves 0.0.0.0 so, inside
        # a container without a network); 0 must not.
        ("0.0.0.0 with NEARPOINT_INSECURE=0", [], {"NEARPOINT_INSECURE": "0"}, "0.0.0.0:0",
         "--listen"),
        ("[::] without TLS", [], None, "[::]:0", "--listen"),
        ("a host name without TLS", [], None, "example.invalid:50051", "--listen"),
    ]
    for what, flags, env, listen, flag in cases:
        code, err = run_start_failure(d, flags, env, listen)
        check(code == 2 and f"flag={flag}" in err and "listening" not in err,
              f"bad-config: {what}: exit 2 naming {flag} (exit {code}: {err.strip()[:300]})")
    # A key that does not belong to the certificate passes the file checks; gRPC refuses it when
    # the port is bound (127.0.0.1 only).
    code, err = run_start_failure(d, ["--tls-cert", p("server.pem"), "--tls-key", p("client.key")])
    check(code == 2 and "start_failed" in err and "TLS key" in err and "listening" not in err,
          f"bad-config: mismatched key: exit 2 (exit {code}: {err.strip()[:300]})")


def health_check(channel):
    """grpc.health.v1.Health/Check with an empty request; the raw response (status 1 = SERVING
    is the bytes 08 01)."""
    call = channel.unary_unary("/grpc.health.v1.Health/Check",
                               request_serializer=lambda x: x, response_deserializer=lambda x: x)
    return call(b"", timeout=10)


def cli(server_target, *flags):
    result = subprocess.run([ARGS.nearpoint, "scene", "create", "--target", server_target,
                             "--timeout-ms", "10000", *flags, os.path.join(ARGS.work, "scene.json")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=60,
                            env={k: v for k, v in os.environ.items()
                                 if k != "NEARPOINT_TOKEN_FILE"})
    return result.returncode, (result.stdout + result.stderr).decode("utf-8", errors="replace")


def cli_health(server_target, *flags):
    result = subprocess.run([ARGS.nearpoint, "health", "--target", server_target,
                             "--timeout-ms", "5000", *flags],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=60,
                            env={k: v for k, v in os.environ.items()
                                 if k != "NEARPOINT_TOKEN_FILE"})
    return result.returncode, (result.stdout + result.stderr).decode("utf-8", errors="replace")


def status_of(fn):
    """None when fn() succeeds, else the failed call's gRPC status code."""
    try:
        fn()
        return None
    except npc.NearpointError as error:
        return error.code
    except grpc.RpcError as error:
        return error.code()


def case_tls(d):
    p = lambda name: os.path.join(d, name)  # noqa: E731
    token = open(p("token"), encoding="ascii").read().strip()
    server = Server(d, "--tls-cert", p("server.pem"), "--tls-key", p("server.key"),
                    "--token-file", p("token"), "--log-level", "debug")
    try:
        cube = [npc.box((0.5, 0.5, 0.5))]
        for host in (server.target, server.localhost):
            with npc.connect(host, timeout=10, tls_ca=p("ca.pem"), token_file=p("token")) as c:
                check(bool(c.register_geometry(cube, name="tls")),
                      f"tls: right token over TLS to {host}: register succeeds")
        with npc.connect(server.target, timeout=10, tls_ca=p("ca.pem"),
                         token_file=p("wrong-token")) as c:
            code = status_of(lambda: c.register_geometry(cube))
            check(code == grpc.StatusCode.UNAUTHENTICATED, f"tls: wrong token: {code}")
        with npc.connect(server.target, timeout=10, tls_ca=p("ca.pem")) as c:
            code = status_of(lambda: c.list_geometries())
            check(code == grpc.StatusCode.UNAUTHENTICATED, f"tls: no token: {code}")
            # Kubernetes probes send no token: the health service is exempt (TLS still applies).
            check(health_check(c._channel) == b"\x08\x01", "tls: health SERVING without a token")
        # Plaintext to the TLS port: the handshake never completes.
        plain = grpc.insecure_channel(server.target)
        code = status_of(lambda: health_check(plain))
        plain.close()
        check(code == grpc.StatusCode.UNAVAILABLE, f"tls: plaintext to the TLS port: {code}")
        # A client that trusts another CA refuses the server's certificate.
        code = status_of(lambda: npc.connect(server.target, timeout=5, tls_ca=p("other-ca.pem"),
                                             token=token))
        check(code == grpc.StatusCode.UNAVAILABLE, f"tls: untrusted server certificate: {code}")

        # The CLI, through the C++ client library.
        code, out = cli(server.target, "--tls-ca", p("ca.pem"), "--token-file", p("token"))
        check(code == 0, f"tls: CLI with --tls-ca and --token-file: exit {code} {out.strip()[:200]}")
        code, out = cli(server.target, "--tls-ca", p("ca.pem"), "--token-file", p("wrong-token"))
        check(code == 1 and "UNAUTHENTICATED" in out,
              f"tls: CLI with a wrong token: exit {code} {out.strip()[:200]}")
        code, out = cli(server.target)
        check(code == 3, f"tls: CLI in plaintext to the TLS port: exit {code} {out.strip()[:200]}")
        # `nearpoint health` (the image's HEALTHCHECK, a probe): no token needed, TLS is.
        code, out = cli_health(server.target, "--tls-ca", p("ca.pem"))
        check(code == 0 and out.strip() == "SERVING",
              f"tls: CLI health over TLS without a token: exit {code} {out.strip()[:200]}")
        code, out = cli_health(server.target)
        check(code == 3, f"tls: CLI health in plaintext to the TLS port: exit {code}")
        # --tls-server-name: the name checked is the given one, not the target's host.
        code, out = cli_health(server.target, "--tls-ca", p("ca.pem"), "--tls-server-name",
                               "localhost")
        check(code == 0, f"tls: CLI health with --tls-server-name localhost: exit {code}")
        code, out = cli_health(server.target, "--tls-ca", p("ca.pem"), "--tls-server-name",
                               "nearpoint.other.example")
        check(code == 3, f"tls: CLI health with a name the certificate lacks: exit {code}")
        code = status_of(lambda: npc.connect(server.target, timeout=5, tls_ca=p("ca.pem"),
                                             tls_server_name="nearpoint.other.example"))
        check(code == grpc.StatusCode.UNAVAILABLE,
              f"tls: Python client, a name the certificate lacks: {code}")
        code, out = cli(server.target, "--tls-ca", p("missing.pem"))
        check(code == 2 and "missing.pem" in out,
              f"tls: CLI with an unreadable --tls-ca: exit {code} {out.strip()[:200]}")
    finally:
        code = server.stop()
    log = server.stderr()
    check(code == 0, f"tls: SIGTERM: nearpointd exits 0 ({code})")
    check("tls=on" in log and "token=required" in log, "tls: the start line says tls=on, token")

    # The same health verb against a plaintext server on loopback.
    plain = Server(d)
    try:
        code, out = cli_health(plain.target)
        check(code == 0 and out.strip() == "SERVING", f"plain: CLI health: exit {code} {out}")
        code, out = cli_health(plain.target, "--service", "nearpoint.v1.DistanceService", "--json")
        check(code == 0 and '"status":"SERVING"' in out,
              f"plain: CLI health of the DistanceService: exit {code} {out}")
        code, out = cli_health(plain.target, "--service", "no.such.Service")
        check(code == 1 and "NOT_FOUND" in out, f"plain: CLI health of an unknown service: {code}")
    finally:
        code = plain.stop()
    check(code == 0, f"plain: SIGTERM: nearpointd exits 0 ({code})")
    code, out = cli_health(plain.target)
    check(code == 3, f"plain: CLI health with no server: exit {code}")
    check("unauthenticated" in log, "tls: refused calls are logged")
    check(token not in log and "s3cr3t" not in log, "tls: no token in the server's log")


def case_mtls(d):
    p = lambda name: os.path.join(d, name)  # noqa: E731
    server = Server(d, "--tls-cert", p("server.pem"), "--tls-key", p("server.key"),
                    "--tls-client-ca", p("ca.pem"))
    try:
        with npc.connect(server.target, timeout=10, tls_ca=p("ca.pem"), tls_cert=p("client.pem"),
                         tls_key=p("client.key")) as c:
            check(bool(c.register_geometry([npc.box((1, 1, 1))])),
                  "mtls: client certificate from the CA: register succeeds")
        code = status_of(lambda: npc.connect(server.target, timeout=5, tls_ca=p("ca.pem")))
        check(code == grpc.StatusCode.UNAVAILABLE, f"mtls: no client certificate: {code}")
        code = status_of(lambda: npc.connect(server.target, timeout=5, tls_ca=p("ca.pem"),
                                             tls_cert=p("other-client.pem"),
                                             tls_key=p("other-client.key")))
        check(code == grpc.StatusCode.UNAVAILABLE, f"mtls: certificate from another CA: {code}")
        code, out = cli(server.target, "--tls-ca", p("ca.pem"), "--tls-cert", p("client.pem"),
                        "--tls-key", p("client.key"))
        check(code == 0, f"mtls: CLI with a client certificate: exit {code} {out.strip()[:200]}")
        code, out = cli(server.target, "--tls-ca", p("ca.pem"))
        check(code == 3, f"mtls: CLI without a client certificate: exit {code} {out.strip()[:200]}")
    finally:
        code = server.stop()
    check(code == 0, f"mtls: SIGTERM: nearpointd exits 0 ({code})")
    check("tls=mutual" in server.stderr(), "mtls: the start line says tls=mutual")


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("case", choices=["bad-config", "tls", "mtls"])
    parser.add_argument("--nearpointd", required=True)
    parser.add_argument("--nearpoint", required=True)
    parser.add_argument("--pythonpath", required=True)
    ARGS = parser.parse_args()
    sys.path.insert(0, ARGS.pythonpath)
    # This script starts nearpointd and the CLI while channels are open. With gRPC's fork support
    # on, each start waits for gRPC's thread pool to go idle, and a channel retrying a refused
    # handshake never does: one CI run timed out so. The children exec at once and share nothing
    # with gRPC, so the support is not needed.
    os.environ["GRPC_ENABLE_FORK_SUPPORT"] = "false"
    import grpc  # noqa: E402
    from nearpoint import client as npc  # noqa: E402

    with tempfile.TemporaryDirectory(prefix="nearpoint_tls_") as work:
        ARGS.work = work
        make_pki(work)
        {"bad-config": case_bad_config, "tls": case_tls, "mtls": case_mtls}[ARGS.case](work)
    if FAILURES:
        print(f"{len(FAILURES)} check(s) failed", file=sys.stderr)
        sys.exit(1)
    print("all checks passed")
