#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""nearpointd's health and reflection services read with gRPC's own schemas.

    check_health_reflection.py NEARPOINTD GRPC_PROTO_DIR PROTOC

nearpointd serves grpc.health.v1 and server reflection itself, from schemas of its own
(proto/grpc/). This check reads them with the upstream schemas (Debian's grpc-proto package,
GRPC_PROTO_DIR), compiled here by protoc for Python, through grpcio: Check and Watch, reflection
v1alpha and v1 (list, a file that builds in protobuf's own Python pool with its dependencies,
NOT_FOUND), then SIGTERM: the open Watch hears NOT_SERVING and ends UNAVAILABLE.
"""
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "common"))
from nearpointd_process import NearpointdProcess  # noqa: E402


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def compile_upstream(proto_dir, protoc, out):
    """health.v1.health_pb2, v1alpha.reflection_pb2 and v1.reflection_pb2 in `out`: rooted below
    grpc/, so that they do not hide grpcio's package `grpc`, and the two reflection.proto files
    have different names in protobuf's pool."""
    for root, name in (("grpc", "health/v1/health.proto"),
                       ("grpc/reflection", "v1alpha/reflection.proto"),
                       ("grpc/reflection", "v1/reflection.proto")):
        subprocess.run([protoc, "-I" + os.path.join(proto_dir, root), "--python_out=" + out, name],
                       check=True, timeout=60)
    sys.path.insert(0, out)


def main():
    nearpointd, proto_dir, protoc = sys.argv[1:4]
    out = tempfile.mkdtemp(prefix="nearpoint-grpc-proto-")
    compile_upstream(proto_dir, protoc, out)
    import grpc  # noqa: E402
    from google.protobuf import descriptor_pb2, descriptor_pool  # noqa: E402
    from health.v1 import health_pb2  # noqa: E402
    from v1 import reflection_pb2 as v1  # noqa: E402
    from v1alpha import reflection_pb2 as v1alpha  # noqa: E402

    server = NearpointdProcess(nearpointd)
    with server:
        channel = grpc.insecure_channel(server.target)
        request, response = health_pb2.HealthCheckRequest, health_pb2.HealthCheckResponse
        check = channel.unary_unary("/grpc.health.v1.Health/Check",
                                    request_serializer=request.SerializeToString,
                                    response_deserializer=response.FromString)
        for service in ("", "nearpoint.v1.DistanceService"):
            answer = check(health_pb2.HealthCheckRequest(service=service), timeout=10)
            if answer.status != health_pb2.HealthCheckResponse.SERVING:
                fail("Check(%r): %s" % (service, answer))
        try:
            check(health_pb2.HealthCheckRequest(service="no.Such"), timeout=10)
            fail("Check of an unknown service answered")
        except grpc.RpcError as error:
            if error.code() != grpc.StatusCode.NOT_FOUND:
                fail("Check of an unknown service: %s" % error.code())

        for version, path in ((v1alpha, "/grpc.reflection.v1alpha.ServerReflection/"),
                              (v1, "/grpc.reflection.v1.ServerReflection/")):
            info = channel.stream_stream(
                path + "ServerReflectionInfo",
                request_serializer=version.ServerReflectionRequest.SerializeToString,
                response_deserializer=version.ServerReflectionResponse.FromString)
            requests = [
                version.ServerReflectionRequest(list_services=""),
                version.ServerReflectionRequest(
                    file_containing_symbol="nearpoint.v1.DistanceService"),
                version.ServerReflectionRequest(file_by_filename="no/such.proto"),
            ]
            listed, described, missing = list(info(iter(requests), timeout=10))
            names = {s.name for s in listed.list_services_response.service}
            expected = {"nearpoint.v1.DistanceService", "grpc.health.v1.Health",
                        "grpc.reflection.v1alpha.ServerReflection",
                        "grpc.reflection.v1.ServerReflection"}
            if not expected <= names:
                fail("%s list_services: %s" % (path, sorted(names)))
            files = [descriptor_pb2.FileDescriptorProto.FromString(data)
                     for data in described.file_descriptor_response.file_descriptor_proto]
            by_name = {file.name: file for file in files}
            pool = descriptor_pool.DescriptorPool()
            added = set()

            def add(name):  # each file after its imports, all from the response alone
                if name in added:
                    return
                if name not in by_name:
                    fail("%s: %s is imported but not in the response" % (path, name))
                for dependency in by_name[name].dependency:
                    add(dependency)
                pool.Add(by_name[name])
                added.add(name)
            add(files[0].name)
            service = pool.FindServiceByName("nearpoint.v1.DistanceService")
            if service.FindMethodByName("StreamPoses").input_type.full_name != \
                    "nearpoint.v1.PoseUpdate":
                fail("%s: StreamPoses does not take nearpoint.v1.PoseUpdate" % path)
            if missing.error_response.error_code != 5 or \
                    missing.original_request.file_by_filename != "no/such.proto":
                fail("%s file_by_filename of a missing file: %s" % (path, missing))

        watch = channel.unary_stream("/grpc.health.v1.Health/Watch",
                                     request_serializer=request.SerializeToString,
                                     response_deserializer=response.FromString)
        statuses = watch(health_pb2.HealthCheckRequest(service=""), timeout=30)
        first = next(statuses)
        if first.status != health_pb2.HealthCheckResponse.SERVING:
            fail("Watch: first %s" % first)
        server.process.send_signal(15)
        seen = []
        try:
            for message in statuses:
                seen.append(message.status)
            fail("Watch ended OK at shutdown")
        except grpc.RpcError as error:
            code = error.code()
        if seen != [health_pb2.HealthCheckResponse.NOT_SERVING] or \
                code != grpc.StatusCode.UNAVAILABLE:
            fail("Watch at SIGTERM: %s then %s" % (seen, code))
        channel.close()
        if server.process.wait(timeout=30) != 0:
            fail("nearpointd exited %d on SIGTERM:\n%s" % (server.process.returncode, server.log()))
    print("ok: Check, Watch to NOT_SERVING at SIGTERM, reflection v1alpha and v1, read with "
          "gRPC's own schemas")


if __name__ == "__main__":
    main()
