#!/usr/bin/env python3
"""Example meshlod client in Python (grpcio), with stubs generated from proto/ at start-up.

    python examples/python/client.py --server 127.0.0.1:50051 [--mesh FILE] [--keep 0.1] [--out OUT.glb]

Simplifies a mesh on the server (with the progressive mesh and the Hausdorff figures), streams the
same simplification, refines it, and checks what comes back. The mesh is a file of yours, sent as
it is (OBJ, PLY, STL, OFF, or glTF as GLB or with its buffers embedded), or, without --mesh, a
small synthetic grid. With --out the server writes the result in the format the extension names
(.glb or .gltf: a GLB with the input's materials and images; .obj; .ply). A simplification that
stops above its target says so and why. Exits non-zero if anything is off, so CI can run it.
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


# The contract's file formats by extension (glTF JSON is read when its buffers are embedded).
INPUT_FORMATS = {".obj": "OBJ", ".ply": "PLY", ".stl": "STL", ".off": "OFF", ".gltf": "GLTF", ".glb": "GLTF"}
OUTPUT_FORMATS = {".obj": "OBJ", ".ply": "PLY", ".gltf": "GLTF", ".glb": "GLTF"}


def mesh_format(pb, path, table):
    """The contract's MeshFormat for `path`'s extension in `table`, or None."""
    name = table.get(os.path.splitext(path)[1].lower())
    return getattr(pb, f"MESH_FORMAT_{name}") if name else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--server", default="127.0.0.1:50051")
    ap.add_argument("--mesh", help="a mesh file to simplify: OBJ, PLY, STL, OFF, glTF/GLB (default: a synthetic grid)")
    ap.add_argument("--keep", type=float, default=0.1, help="fraction of the faces to keep (0.1 keeps 10%%)")
    ap.add_argument("--out", help="write the simplified mesh here: .glb, .gltf, .obj or .ply")
    args = ap.parse_args()
    if not 0 < args.keep <= 1:
        ap.error(f"--keep {args.keep} is outside (0, 1]")
    if args.out and os.path.splitext(args.out)[1].lower() not in OUTPUT_FORMATS:
        ap.error(f"--out {args.out}: give a .glb, .gltf, .obj or .ply file")
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
        # Unknown extensions are sniffed by the server from the content.
        kind = mesh_format(pb, args.mesh, INPUT_FORMATS) or pb.MESH_FORMAT_UNSPECIFIED
        mesh_input = pb.MeshInput(file=pb.EncodedMesh(data=data, format=kind))
        expected_faces = None
    else:
        positions, indices = wavy_grid(40)
        mesh_input = pb.MeshInput(mesh=pb.Mesh(positions=positions, indices=indices))
        expected_faces = len(indices) // 3
    options = pb.SimplifyOptions(target_ratio=1 - args.keep, return_progressive=True, compute_hausdorff=True)
    request = pb.SimplifyRequest(input=mesh_input, options=options)
    if args.out:
        # The server encodes the result (a GLB keeps the input's materials and images).
        request.output_format = mesh_format(pb, args.out, OUTPUT_FORMATS)
    try:
        response = stub.Simplify(request, timeout=600)
    except grpc.RpcError as e:
        raise SystemExit(f"Simplify failed: {e.details()} ({e.code().name})")
    stats = response.stats
    faces_in, faces_out = stats.faces_in, stats.faces_out
    assert expected_faces is None or faces_in == expected_faces, stats
    if args.out:
        assert response.encoded.data, "no encoded result"
    else:
        assert len(response.mesh.indices) == 3 * faces_out
    assert response.hausdorff.hausdorff > 0
    print(f"Simplify: {faces_in} -> {faces_out} faces (target {stats.target_faces}), "
          f"Hausdorff {response.hausdorff.hausdorff:.5f} paper units, "
          f"{len(response.progressive.splits)} vertex splits")
    if faces_out > stats.target_faces:
        # Not an error: the legality rules held the last edges. Say which.
        refused = {f.name: getattr(stats.refused, f.name) for f in stats.refused.DESCRIPTOR.fields}
        held = ", ".join(f"{n} {rule}" for rule, n in sorted(refused.items(), key=lambda x: -x[1]) if n)
        print(f"  the target was not reached: {stats.stop_reason} ({held or 'no refusal counted'})")
    if expected_faces is not None:
        # The synthetic grid always reaches its target.
        assert faces_out <= stats.target_faces, stats
        assert len(response.progressive.splits) > 0

    splits = 0
    if args.out:
        with open(args.out, "wb") as f:
            f.write(response.encoded.data)
        print(f"wrote {args.out} ({len(response.encoded.data)} bytes)")

    stream_request = pb.SimplifyRequest(input=mesh_input, options=options)
    for message in stub.SimplifyStream(stream_request, timeout=600):
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
