#!/usr/bin/env python3
"""Example meshlod client in Python (grpcio), with stubs generated from proto/ at start-up.

    python examples/python/client.py --server 127.0.0.1:50051 [--mesh FILE.obj|FILE.ply] [--out OUT.obj]

Simplifies a mesh on the server (with the progressive mesh and the Hausdorff figures), streams the
same simplification, refines it, and checks what comes back. The mesh is a file of yours (sent as
it is: the server reads OBJ and PLY) or, without --mesh, a small synthetic grid. With --out the
simplified mesh is written as OBJ. Exits non-zero if anything is off, so CI can run it.
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


def write_obj(path, mesh):
    """Writes a contract Mesh as OBJ (1-based indices)."""
    with open(path, "w") as f:
        p = mesh.positions
        for i in range(0, len(p), 3):
            f.write(f"v {p[i]} {p[i + 1]} {p[i + 2]}\n")
        t = mesh.indices
        for i in range(0, len(t), 3):
            f.write(f"f {t[i] + 1} {t[i + 1] + 1} {t[i + 2] + 1}\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--server", default="127.0.0.1:50051")
    ap.add_argument("--mesh", help="an OBJ or PLY file to simplify (default: a synthetic grid)")
    ap.add_argument("--ratio", type=float, default=0.9, help="fraction of the faces to remove")
    ap.add_argument("--out", help="write the simplified mesh here (OBJ)")
    args = ap.parse_args()
    generate_stubs()
    import grpc
    from meshlod.v1 import meshlod_pb2 as pb
    from meshlod.v1 import meshlod_pb2_grpc as rpc

    channel = grpc.insecure_channel(args.server, options=[("grpc.max_receive_message_length", 256 << 20)])
    grpc.channel_ready_future(channel).result(timeout=30)
    stub = rpc.MeshLodStub(channel)
    if args.mesh:
        with open(args.mesh, "rb") as f:
            data = f.read()
        kind = {".obj": pb.MESH_FORMAT_OBJ, ".ply": pb.MESH_FORMAT_PLY}.get(os.path.splitext(args.mesh)[1].lower(),
                                                                           pb.MESH_FORMAT_UNSPECIFIED)
        mesh_input = pb.MeshInput(file=pb.EncodedMesh(data=data, format=kind))
        expected_faces = None
    else:
        positions, indices = wavy_grid(40)
        mesh_input = pb.MeshInput(mesh=pb.Mesh(positions=positions, indices=indices))
        expected_faces = len(indices) // 3
    request = pb.SimplifyRequest(
        input=mesh_input,
        options=pb.SimplifyOptions(target_ratio=args.ratio, return_progressive=True, compute_hausdorff=True))
    response = stub.Simplify(request, timeout=600)
    faces_in, faces_out = response.stats.faces_in, response.stats.faces_out
    assert expected_faces is None or faces_in == expected_faces, response.stats
    assert faces_out <= round(faces_in * (1 - args.ratio)) + 1, response.stats
    assert len(response.mesh.indices) == 3 * faces_out
    assert response.hausdorff.hausdorff > 0
    assert len(response.progressive.splits) > 0
    print(f"Simplify: {faces_in} -> {faces_out} faces, Hausdorff {response.hausdorff.hausdorff:.5f} paper units, "
          f"{len(response.progressive.splits)} vertex splits")

    splits = 0
    if args.out:
        write_obj(args.out, response.mesh)
        print(f"wrote {args.out}")

    for message in stub.SimplifyStream(request, timeout=600):
        kind = message.WhichOneof("item")
        if kind == "splits":
            splits += len(message.splits.splits)
    assert splits == len(response.progressive.splits), (splits, len(response.progressive.splits))
    print(f"SimplifyStream: {splits} vertex splits streamed")

    refined = stub.Refine(pb.RefineRequest(input=mesh_input, etc=1.0), timeout=600)
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
