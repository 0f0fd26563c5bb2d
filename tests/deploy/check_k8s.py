#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""deploy/k8s (issue 23, item 4): the example overlay renders (kubectl kustomize), the tree passes
yamllint, and the rendered objects agree with the binaries they run:

- every nearpointd flag in the Deployment exists (`nearpointd --help`), the container port is
  --listen's, the Service targets it, the probes dial that port with flags `nearpoint health`
  has, check the certificate for the Service's name and read files from the mounted Secret;
- terminationGracePeriodSeconds is above --drain-timeout-ms; --workers fits the CPU limit;
  requests and limits are set; the pod runs as non-root with a read-only root filesystem;
- every file the flags name lies under a mounted volume, and the Secrets are referenced, not
  shipped;
- the ConfigMap's scene files load: a real nearpointd on 127.0.0.1:0 preloads them and exits 0
  on SIGTERM;
- overlays/sharded (issue 24): a headless Service of the nearpointd pods, HAProxy routing by
  x-nearpoint-scene with consistent hashing to that Service's full DNS name and the gRPC health
  check of deploy/haproxy/, the Service `nearpoint` leading to the routers; both HAProxy
  configurations pass `haproxy -c` (when haproxy is installed).

    check_k8s.py --source-dir . --nearpointd build/server/nearpointd --nearpoint build/client/nearpoint

Exit 77 (ctest: skipped) when kubectl or yamllint is not installed: said, not silently passed.
"""
import argparse
import ctypes
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import xml.dom.minidom

try:
    import yaml
except ImportError:
    yaml = None

FAILURES = []


def check(condition, what):
    print(("ok   " if condition else "FAIL ") + what, flush=True)
    if not condition:
        FAILURES.append(what)


def die_with_parent():
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


def flags_of_help(command):
    out = subprocess.run(command + ["--help"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         timeout=30).stdout.decode()
    return set(re.findall(r"(--[a-z][a-z0-9-]*)", out))


def parse_args(args):
    """["--a=1", "--b", "2", "--c"] → {"--a": ["1"], "--b": ["2"], "--c": [""]}"""
    parsed, i = {}, 0
    while i < len(args):
        arg = args[i]
        if "=" in arg:
            key, value = arg.split("=", 1)
        elif i + 1 < len(args) and not args[i + 1].startswith("--"):
            key, value = arg, args[i + 1]
            i += 1
        else:
            key, value = arg, ""
        parsed.setdefault(key, []).append(value)
        i += 1
    return parsed


def cpu(quantity):
    q = str(quantity)
    return float(q[:-1]) / 1000 if q.endswith("m") else float(q)


def haproxy_valid(config_text, tls_dir_in_config, work):
    """`haproxy -c` on `config_text` with the TLS files it names made up (self-signed) in
    `work`; (ok, output). None when haproxy or openssl is missing."""
    if not shutil.which("haproxy") or not shutil.which("openssl"):
        return None
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
                    "-subj", "/CN=nearpoint", "-keyout", os.path.join(work, "tls.pem.key"),
                    "-out", os.path.join(work, "tls.pem")],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=60, check=True)
    shutil.copy(os.path.join(work, "tls.pem"), os.path.join(work, "ca.crt"))
    path = os.path.join(work, "haproxy.cfg")
    with open(path, "w", encoding="utf-8") as f:
        f.write(config_text.replace(tls_dir_in_config, work + "/"))
    env = dict(os.environ, NEARPOINT_PROXY_LISTEN="127.0.0.1:50050",
               NEARPOINT_REPLICA_1="127.0.0.1:50051", NEARPOINT_REPLICA_2="127.0.0.1:50052",
               NEARPOINT_REPLICA_3="127.0.0.1:50053")
    result = subprocess.run(["haproxy", "-c", "-f", path], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, timeout=60, env=env)
    return result.returncode == 0, result.stdout.decode(errors="replace")


def check_sharded(source_dir, k8s):
    """overlays/sharded (issue 24): a headless Service of the nearpointd pods, HAProxy routing by
    the scene header with consistent hashing to that Service's DNS name, the health check bytes
    of deploy/haproxy/, and the Service `nearpoint` leading to the routers."""
    rendered = subprocess.run(["kubectl", "kustomize", os.path.join(k8s, "overlays", "sharded")],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=60)
    check(rendered.returncode == 0, "kubectl kustomize overlays/sharded " +
          rendered.stderr.decode())
    if rendered.returncode != 0:
        return
    by_name = {}
    for doc in yaml.safe_load_all(rendered.stdout):
        if doc:
            by_name[(doc["kind"], doc["metadata"]["name"])] = doc
    server = by_name.get(("Deployment", "nearpoint"))
    router = by_name.get(("Deployment", "nearpoint-router"))
    headless = by_name.get(("Service", "nearpoint-replicas"))
    front = by_name.get(("Service", "nearpoint"))
    check(None not in (server, router, headless, front),
          "sharded: Deployments nearpoint and nearpoint-router, Services nearpoint and "
          "nearpoint-replicas")
    if None in (server, router, headless, front):
        return
    namespace = headless["metadata"].get("namespace", "default")
    server_labels = server["spec"]["template"]["metadata"].get("labels", {})
    router_labels = router["spec"]["template"]["metadata"].get("labels", {})

    def selects(service, labels):
        selector = service["spec"].get("selector") or {}
        return bool(selector) and all(labels.get(k) == v for k, v in selector.items())

    check(headless["spec"].get("clusterIP") == "None", "sharded: nearpoint-replicas is headless")
    check(selects(headless, server_labels) and not selects(headless, router_labels),
          "sharded: nearpoint-replicas selects the nearpointd pods only")
    check(selects(front, router_labels) and not selects(front, server_labels),
          "sharded: the Service nearpoint selects the routers only")
    server_port = {p["name"]: p["containerPort"]
                   for p in server["spec"]["template"]["spec"]["containers"][0]["ports"]}["grpc"]
    check(any(p["targetPort"] in ("grpc", server_port) for p in headless["spec"]["ports"]),
          "sharded: nearpoint-replicas targets the gRPC port")

    pod = router["spec"]["template"]["spec"]
    container = pod["containers"][0]
    mounts = {m["name"]: m["mountPath"] for m in container["volumeMounts"]}
    volumes = {v["name"]: v for v in pod["volumes"]}
    config_map_name = volumes.get("config", {}).get("configMap", {}).get("name", "")
    config_map = next((doc for (kind, name), doc in by_name.items()
                       if kind == "ConfigMap" and name.startswith("nearpoint-router")
                       and name == config_map_name), None)
    check(config_map is not None and "haproxy.cfg" in config_map.get("data", {}),
          f"sharded: the router mounts its ConfigMap ({config_map_name}) holding haproxy.cfg")
    if config_map is None:
        return
    config = config_map["data"]["haproxy.cfg"]
    check(f"{mounts.get('config', '?')}/haproxy.cfg" in container["command"],
          "sharded: haproxy runs the mounted haproxy.cfg")
    check(re.search(r"^\s*balance hdr\(x-nearpoint-scene\)\s*$", config, re.M) is not None,
          "sharded: balance hdr(x-nearpoint-scene)")
    check(re.search(r"^\s*hash-type consistent\s*$", config, re.M) is not None,
          "sharded: hash-type consistent")
    fqdn = f"{headless['metadata']['name']}.{namespace}.svc.cluster.local:{server_port}"
    check(re.search(r"^\s*server-template \S+ \d+ " + re.escape(fqdn) + r"\s*$", config, re.M)
          is not None, f"sharded: server-template resolves {fqdn}")
    router_port = {p["name"]: p["containerPort"] for p in container["ports"]}
    bind = re.search(r"^\s*bind :(\d+) ssl crt (\S+)", config, re.M)
    check(bind is not None and int(bind.group(1)) == router_port.get("grpc"),
          "sharded: the router's TLS frontend listens on its grpc containerPort")
    check(any(p["targetPort"] in ("grpc", router_port.get("grpc")) for p in front["spec"]["ports"]),
          "sharded: the Service nearpoint targets the router's port")
    tls_mount = mounts.get("tls", "?")
    if bind:
        check(bind.group(2).startswith(tls_mount + "/"), "sharded: the certificate is mounted")
    check(volumes.get("tls", {}).get("secret", {}).get("secretName") == "nearpoint-tls",
          "sharded: the router's certificate is the base's Secret nearpoint-tls")

    # One health check, the same bytes in both configurations, as the script makes them.
    made = subprocess.run([sys.executable, os.path.join(source_dir, "deploy", "haproxy",
                                                        "health_check_bytes.py")],
                          stdout=subprocess.PIPE, timeout=60).stdout.decode()
    expected = dict(line.rsplit(" ", 1) for line in made.splitlines())
    with open(os.path.join(source_dir, "deploy", "haproxy", "nearpoint.cfg"),
              encoding="utf-8") as f:
        local = f.read()
    for name, text in (("overlays/sharded/haproxy.cfg", config),
                       ("deploy/haproxy/nearpoint.cfg", local)):
        check(f"tcp-check send-binary {expected['send-binary']}" in text and
              f"tcp-check expect binary {expected['expect binary']}" in text,
              f"{name}: the gRPC health check bytes of health_check_bytes.py")
    for name, text, tls_dir in (("overlays/sharded/haproxy.cfg", config, tls_mount + "/"),
                                ("deploy/haproxy/nearpoint.cfg", local, "/nonexistent/")):
        with tempfile.TemporaryDirectory(prefix="nearpoint_haproxy_") as work:
            verdict = haproxy_valid(text, tls_dir, work)
        if verdict is None:
            print(f"skip {name}: haproxy -c (haproxy or openssl is not installed)")
        else:
            check(verdict[0], f"haproxy -c {name}\n{verdict[1][-600:]}")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("--nearpointd", required=True)
    parser.add_argument("--nearpoint", required=True)
    args = parser.parse_args()
    k8s = os.path.join(args.source_dir, "deploy", "k8s")
    if yaml is None:
        print("SKIPPED: python3-yaml is not installed")
        return 77
    for tool in ("kubectl", "yamllint"):
        if not shutil.which(tool):
            print(f"SKIPPED: {tool} is not installed (Debian: kubernetes-client, yamllint)")
            return 77

    # The cluster DDS configuration shipped next to the loopback one is well-formed XML.
    try:
        xml.dom.minidom.parse(os.path.join(args.source_dir, "deploy", "cyclonedds-cluster.xml"))
        check(True, "deploy/cyclonedds-cluster.xml is well-formed")
    except Exception as error:  # noqa: BLE001 - any parse failure is the finding
        check(False, f"deploy/cyclonedds-cluster.xml: {error}")
    lint = subprocess.run(["yamllint", "-s", "-c", os.path.join(k8s, ".yamllint"), k8s],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=60)
    check(lint.returncode == 0, "yamllint -s deploy/k8s\n" + lint.stdout.decode())
    rendered = subprocess.run(["kubectl", "kustomize", os.path.join(k8s, "overlays", "example")],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=60)
    check(rendered.returncode == 0, "kubectl kustomize overlays/example " +
          rendered.stderr.decode())
    if rendered.returncode != 0:
        return 1
    objects = {}
    for doc in yaml.safe_load_all(rendered.stdout):
        if doc:
            objects.setdefault(doc["kind"], []).append(doc)
    for kind in ("Deployment", "Service", "ConfigMap", "PodDisruptionBudget",
                 "HorizontalPodAutoscaler"):
        check(len(objects.get(kind, [])) == 1, f"one {kind}")
    check("Secret" not in objects, "no Secret shipped (referenced only)")
    deployment, service = objects["Deployment"][0], objects["Service"][0]
    configmap = objects["ConfigMap"][0]
    pod = deployment["spec"]["template"]["spec"]
    container = pod["containers"][0]

    server_flags = flags_of_help([args.nearpointd])
    health_flags = flags_of_help([args.nearpoint, "health"])
    flags = parse_args(container["args"])
    unknown = sorted(set(flags) - server_flags)
    check(not unknown, f"every nearpointd flag exists (unknown: {unknown})")
    listen = flags.get("--listen", ["127.0.0.1:50051"])[0]
    port = int(listen.rsplit(":", 1)[1])
    ports = {p["name"]: p["containerPort"] for p in container["ports"]}
    check(ports.get("grpc") == port, f"containerPort grpc = the --listen port {port}")
    check(any(p["targetPort"] in ("grpc", port) for p in service["spec"]["ports"]),
          "the Service targets the gRPC port")
    check("--tls-cert" in flags and "--tls-key" in flags or "--insecure" in flags,
          "non-loopback --listen with TLS (or --insecure)")
    # The scrape annotations, the metrics containerPort and --metrics-listen name one port.
    annotations = deployment["spec"]["template"].get("metadata", {}).get("annotations", {})
    metrics_listen = flags.get("--metrics-listen", [""])[0]
    check(bool(metrics_listen), "--metrics-listen is set (the pod is scraped)")
    if metrics_listen:
        metrics_port = int(metrics_listen.rsplit(":", 1)[1])
        check(annotations.get("prometheus.io/scrape") == "true", "prometheus.io/scrape: true")
        check(annotations.get("prometheus.io/port") == str(metrics_port),
              f"prometheus.io/port = the --metrics-listen port {metrics_port}")
        check(annotations.get("prometheus.io/path") == "/metrics", "prometheus.io/path: /metrics")
        check(ports.get("metrics") == metrics_port,
              f"containerPort metrics = the --metrics-listen port {metrics_port}")

    drain_s = int(flags.get("--drain-timeout-ms", ["5000"])[0]) / 1000
    grace = pod.get("terminationGracePeriodSeconds", 30)
    check(grace > drain_s, f"terminationGracePeriodSeconds {grace} > drain timeout {drain_s} s")
    resources = container.get("resources", {})
    check(all(k in resources.get(r, {}) for r in ("requests", "limits")
              for k in ("cpu", "memory")), "cpu and memory requests and limits set")
    workers = int(flags.get("--workers", ["0"])[0])
    check(0 < workers <= cpu(resources["limits"]["cpu"]),
          f"--workers {workers} set and within the CPU limit {resources['limits']['cpu']}")
    pod_security = pod.get("securityContext", {})
    security = container.get("securityContext", {})
    check(pod_security.get("runAsNonRoot") is True and pod_security.get("runAsUser", 0) != 0,
          "runs as non-root")
    check(security.get("readOnlyRootFilesystem") is True, "read-only root filesystem")
    check(security.get("allowPrivilegeEscalation") is False, "no privilege escalation")

    mounts = {m["name"]: m["mountPath"] for m in container["volumeMounts"]}
    volumes = {v["name"]: v for v in pod["volumes"]}

    def mounted(path):
        return any(path.startswith(mount.rstrip("/") + "/") for mount in mounts.values())

    for flag in ("--tls-cert", "--tls-key", "--tls-client-ca", "--token-file", "--scene"):
        for path in flags.get(flag, []):
            check(mounted(path), f"{flag} {path} is under a mounted volume")
    secrets = sorted(v["secret"]["secretName"] for v in volumes.values() if "secret" in v)
    check(secrets == ["nearpoint-tls", "nearpoint-token"], f"Secrets referenced: {secrets}")

    for kind in ("readinessProbe", "livenessProbe"):
        probe = container.get(kind, {})
        command = probe.get("exec", {}).get("command", [])
        check(command[:2] == ["nearpoint", "health"], f"{kind}: nearpoint health")
        probe_flags = parse_args(command[2:])
        unknown = sorted(set(probe_flags) - health_flags)
        check(not unknown, f"{kind}: every flag exists (unknown: {unknown})")
        target = probe_flags.get("--target", [""])[0]
        check(target.endswith(f":{port}"), f"{kind}: dials the --listen port ({target})")
        if "--tls-cert" in flags:
            ca = probe_flags.get("--tls-ca", [""])[0]
            check(ca.startswith(mounts.get("tls", "?")), f"{kind}: --tls-ca from the TLS Secret")
            check(probe_flags.get("--tls-server-name", [""])[0] == service["metadata"]["name"],
                  f"{kind}: checks the certificate for the Service's name")
        check("--token-file" not in probe_flags, f"{kind}: no token (health is exempt)")
        timeout_ms = int(probe_flags.get("--timeout-ms", ["10000"])[0])
        check(timeout_ms < probe.get("timeoutSeconds", 1) * 1000,
              f"{kind}: the CLI's deadline {timeout_ms} ms is within timeoutSeconds")
    check(objects["HorizontalPodAutoscaler"][0]["spec"]["minReplicas"] >
          objects["PodDisruptionBudget"][0]["spec"].get("minAvailable", 0),
          "the PodDisruptionBudget leaves room for a voluntary eviction")

    # The scene files the ConfigMap carries load in a real nearpointd (loopback only).
    with tempfile.TemporaryDirectory(prefix="nearpoint_k8s_") as work:
        scene_args = []
        for name, content in configmap.get("data", {}).items():
            path = os.path.join(work, name)
            with open(path, "w", encoding="utf-8") as f:
                f.write(content)
            scene_args += ["--scene", path]
        port_file = os.path.join(work, "port")
        with tempfile.TemporaryFile() as log:
            server = subprocess.Popen(
                [args.nearpointd, "--listen", "127.0.0.1:0", "--port-file", port_file,
                 "--workers", str(workers), "--drain-timeout-ms",
                 flags.get("--drain-timeout-ms", ["5000"])[0], *scene_args],
                stdout=subprocess.DEVNULL, stderr=log, preexec_fn=die_with_parent)
            deadline = time.monotonic() + 20
            while not os.path.exists(port_file) and server.poll() is None and \
                    time.monotonic() < deadline:
                time.sleep(0.05)
            started = os.path.exists(port_file)
            if server.poll() is None:
                server.send_signal(signal.SIGTERM)
            try:
                code = server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()
                code = server.wait()
            log.seek(0)
            text = log.read().decode(errors="replace")
        check(started and code == 0 and text.count("scene_loaded") == len(scene_args) // 2,
              f"the ConfigMap's scenes load in nearpointd (exit {code})\n{text[-600:]}")

    check_sharded(args.source_dir, k8s)

    if FAILURES:
        print(f"{len(FAILURES)} check(s) failed", file=sys.stderr)
        return 1
    print("all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
