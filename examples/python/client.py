#!/usr/bin/env python3
"""Example meshlod client in Python (grpcio), with stubs generated from proto/ at start-up.

    python examples/python/client.py --server 127.0.0.1:50051

Builds a small grid mesh, asks the server to simplify it (with the progressive mesh and the
Hausdorff figures), streams the same simplification, refines it, and checks what comes back.
Exits non-zero if anything is off, so CI can run it.
"""
import argparse
import math
import os
import sys
import tempfile

from grpc_tools import protoc

HERE = os.path.dirname(os.path.abspath(__file__))
PROTO_ROOT = os.path.normpath(os.path.join(HERE, "..", "..", "proto"))


def generate_stubs():
    out = tempfile.mkdtemp(prefix="meshlod-stubs-")
    import grpc_tools
    well_known = os.path.join(os.path.dirname(grpc_tools.__file__), "_proto")
    code = protoc.main(["protoc", f"-I{PROTO_ROOT}", f"-I{well_known}", f"--python_out={out}",
                        f"--grpc_python_out={out}", os.path.join(PROTO_ROOT, "meshlod/v1/meshlod.proto")])
    if code != 0:
        raise SystemExit(f"protoc failed with {code}")
    sys.path.insert(0, out)


def wavy_grid(n):
    """An n × n grid over [-1, 1]², gently waved: 2 n² triangles."""
    positions, indices = [], []
    for i in range(n + 1):
        for j in range(n + 1):
            x, y = 2 * i / n - 1, 2 * j / n - 1
            positions += [x, y, 0.2 * math.sin(3 * x) * math.cos(2 * y)]
    for i in range(n):
        for j in range(n):
            a, b, c, d = i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1
            indices += [a, b, c, a, c, d]
    return positions, indices


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--server", default="127.0.0.1:50051")
    args = ap.parse_args()
    generate_stubs()
    import grpc
    from meshlod.v1 import meshlod_pb2 as pb
    from meshlod.v1 import meshlod_pb2_grpc as rpc

    channel = grpc.insecure_channel(args.server, options=[("grpc.max_receive_message_length", 256 << 20)])
    grpc.channel_ready_future(channel).result(timeout=30)
    stub = rpc.MeshLodStub(channel)
    positions, indices = wavy_grid(40)
    mesh = pb.Mesh(positions=positions, indices=indices)
    request = pb.SimplifyRequest(
        input=pb.MeshInput(mesh=mesh),
        options=pb.SimplifyOptions(target_ratio=0.9, return_progressive=True, compute_hausdorff=True))
    response = stub.Simplify(request, timeout=60)
    faces_in, faces_out = response.stats.faces_in, response.stats.faces_out
    assert faces_in == len(indices) // 3, response.stats
    assert faces_out <= faces_in // 10 + 1, response.stats
    assert len(response.mesh.indices) == 3 * faces_out
    assert response.hausdorff.hausdorff > 0
    assert len(response.progressive.splits) > 0
    print(f"Simplify: {faces_in} -> {faces_out} faces, Hausdorff {response.hausdorff.hausdorff:.5f} paper units, "
          f"{len(response.progressive.splits)} vertex splits")

    splits = 0
    for message in stub.SimplifyStream(request, timeout=60):
        kind = message.WhichOneof("item")
        if kind == "splits":
            splits += len(message.splits.splits)
    assert splits == len(response.progressive.splits), (splits, len(response.progressive.splits))
    print(f"SimplifyStream: {splits} vertex splits streamed")

    refined = stub.Refine(pb.RefineRequest(input=pb.MeshInput(mesh=mesh), etc=1.0), timeout=60)
    assert refined.stats.faces_out > faces_in
    print(f"Refine: {faces_in} -> {refined.stats.faces_out} faces (ETC {refined.stats.etc})")

    try:
        stub.Simplify(pb.SimplifyRequest(input=pb.MeshInput(mesh=pb.Mesh(positions=[0, 0, 0], indices=[0, 0, 5]))))
        raise SystemExit("an invalid mesh was accepted")
    except grpc.RpcError as e:
        assert e.code() == grpc.StatusCode.INVALID_ARGUMENT, e
        print(f"invalid input refused: {e.details()}")
    print("python client: all checks passed")


if __name__ == "__main__":
    main()
