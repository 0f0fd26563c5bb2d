# SPDX-License-Identifier: Apache-2.0
"""A real nearpointd child process on 127.0.0.1, for the Python process-boundary tests.

    with NearpointdProcess(path_to_nearpointd, extra_args) as server:
        env = server.client_env()   # NEARPOINT_TARGET=127.0.0.1:PORT, Cyclone DDS on loopback

The server binds 127.0.0.1:0 and reports its port through --port-file; Cyclone DDS is pointed at
deploy/cyclonedds-loopback.xml (the tests never touch another network). On exit the server is
sent SIGTERM and must drain and exit 0.
"""
import os
import signal
import subprocess
import tempfile
import time

_LOOPBACK_XML = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "deploy",
                             "cyclonedds-loopback.xml")


def loopback_env(base=None):
    env = dict(os.environ if base is None else base)
    env["CYCLONEDDS_URI"] = "file://" + os.path.realpath(_LOOPBACK_XML)
    return env


class NearpointdProcess:
    def __init__(self, nearpointd, args=(), start_timeout_s=30):
        self.nearpointd = nearpointd
        self.args = list(args)
        self.start_timeout_s = start_timeout_s
        self.process = None
        self.port = None

    def __enter__(self):
        self._dir = tempfile.TemporaryDirectory(prefix="nearpointd-")
        port_file = os.path.join(self._dir.name, "port")
        self._log = open(os.path.join(self._dir.name, "log"), "w+")
        self.process = subprocess.Popen(
            [self.nearpointd, "--listen", "127.0.0.1:0", "--port-file", port_file] + self.args,
            stdout=subprocess.DEVNULL, stderr=self._log, env=loopback_env())
        deadline = time.monotonic() + self.start_timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError("nearpointd exited %d before listening:\n%s"
                                   % (self.process.returncode, self.log()))
            if os.path.exists(port_file) and open(port_file).read().strip():
                self.port = int(open(port_file).read().strip())
                return self
            time.sleep(0.05)
        self.process.kill()
        raise RuntimeError("nearpointd did not write its port file within %d s:\n%s"
                           % (self.start_timeout_s, self.log()))

    def log(self):
        self._log.flush()
        self._log.seek(0)
        return self._log.read()

    @property
    def target(self):
        return "127.0.0.1:%d" % self.port

    def client_env(self, base=None):
        env = loopback_env(base)
        env["NEARPOINT_TARGET"] = self.target
        return env

    def __exit__(self, kind, value, traceback):
        code = None
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                code = self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        else:
            code = self.process.returncode
        log = self.log()
        self._log.close()
        self._dir.cleanup()
        if kind is None and code != 0:
            raise RuntimeError("nearpointd exited %s on SIGTERM:\n%s" % (code, log))
        return False
