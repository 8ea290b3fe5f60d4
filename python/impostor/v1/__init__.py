"""Generated protobuf and gRPC stubs of the impostor.v1 protocol (proto/impostor/v1).

The ``*_pb2.py`` and ``*_pb2_grpc.py`` modules are generated at build time
(python/CMakeLists.txt, or setup.py for ``pip install ./python``) and never
checked in.
"""
