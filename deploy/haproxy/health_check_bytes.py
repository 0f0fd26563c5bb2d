#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Prints, as hex, the bytes HAProxy sends to check a nearpointd replica (deploy/haproxy/*.cfg,
`tcp-check send-binary`): one gRPC health check (grpc.health.v1.Health/Check, service "") over
cleartext HTTP/2, and the answer it expects (`tcp-check expect binary`: the gRPC message of
HealthCheckResponse{status: SERVING}). `--tls` is not needed: a TLS backend is checked with
`check-ssl` and the same bytes inside TLS (ALPN h2)."""


def string(value: bytes) -> bytes:
    assert len(value) < 127  # 7-bit length prefix, no Huffman coding
    return bytes([len(value)]) + value


def frame(kind: int, flags: int, stream: int, payload: bytes) -> bytes:
    return len(payload).to_bytes(3, "big") + bytes([kind, flags]) + stream.to_bytes(4, "big") + payload


# HPACK (RFC 7541): indexed :method POST (static 3) and :scheme http (static 6); literals without
# indexing whose names are static entries 4 (:path), 1 (:authority) and 31 (content-type); and
# a literal with a new name (te).
headers = (bytes([0x83, 0x86]) + bytes([0x04]) + string(b"/grpc.health.v1.Health/Check") +
           bytes([0x01]) + string(b"nearpoint") + bytes([0x0F, 0x10]) +
           string(b"application/grpc") + bytes([0x00]) + string(b"te") + string(b"trailers"))
request = (b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" +   # the connection preface
           frame(4, 0, 0, b"") +                   # SETTINGS, empty
           frame(1, 0x4, 1, headers) +             # HEADERS, END_HEADERS
           frame(0, 0x1, 1, bytes(5)))             # DATA, END_STREAM: an empty gRPC message
serving = bytes([0, 0, 0, 0, 2, 0x08, 0x01])       # a 2-byte gRPC message: status = SERVING

print("send-binary", request.hex())
print("expect binary", serving.hex())
