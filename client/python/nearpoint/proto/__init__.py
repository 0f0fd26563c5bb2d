# SPDX-License-Identifier: Apache-2.0
"""The protobuf and gRPC modules generated from proto/nearpoint/v1 (nearpoint_*_pb2,
nearpoint_*_pb2_grpc), for callers that build messages themselves; nearpoint.client wraps them."""
