"""Two arithmetic backends with one interface: NodeMath adds shader math
nodes to a node tree and returns their output sockets; FloatMath computes
the same operations on Python floats with the Math node's semantics.

Blender has no API that evaluates a shader node, so math written once
against this interface (octahedral_frame.py) both builds the atlas material
and runs as plain Python: the tests check the very arithmetic the material
does.
"""
from __future__ import annotations

import math
from typing import Any, Tuple, Union

import bpy

Socket = Union[bpy.types.NodeSocket, float]
# A FloatMath vector is a 3-tuple; a NodeMath vector a vector socket.
Value = Any


class _Composites:
    """Operations both backends build from math()."""

    def math(self, op: str, a: Value, b: Value = 0.0, clamp: bool = False) -> Value:
        raise NotImplementedError

    def lerp(self, a: Value, b: Value, t: Value) -> Value:
        return self.math("ADD", a, self.math("MULTIPLY", t, self.math("SUBTRACT", b, a)))

    def sign_not_zero(self, v: Value) -> Value:
        return self.math("SUBTRACT", 1.0, self.math("MULTIPLY", 2.0, self.math("LESS_THAN", v, 0.0)))


class NodeMath(_Composites):
    """Adds nodes to `tree`, left to right in the order they are made."""

    def __init__(self, tree: bpy.types.NodeTree) -> None:
        self.tree = tree
        self.x = -1800

    def _input(self, node: bpy.types.Node, index: int, value: Socket) -> None:
        if isinstance(value, (int, float)):
            node.inputs[index].default_value = float(value)
        else:
            self.tree.links.new(value, node.inputs[index])

    def _node(self, kind: str) -> bpy.types.Node:
        node = self.tree.nodes.new(kind)
        node.location = (self.x, 0)
        self.x += 20
        return node

    def math(self, op: str, a: Socket, b: Socket = 0.0, clamp: bool = False) -> bpy.types.NodeSocket:
        node = self._node("ShaderNodeMath")
        node.operation = op
        node.use_clamp = clamp
        self._input(node, 0, a)
        self._input(node, 1, b)
        return node.outputs[0]

    def separate(self, vector: bpy.types.NodeSocket) -> Tuple[bpy.types.NodeSocket, ...]:
        node = self._node("ShaderNodeSeparateXYZ")
        self.tree.links.new(vector, node.inputs[0])
        return node.outputs[0], node.outputs[1], node.outputs[2]

    def combine(self, x: Socket, y: Socket, z: Socket = 0.0) -> bpy.types.NodeSocket:
        node = self._node("ShaderNodeCombineXYZ")
        for i, v in enumerate((x, y, z)):
            self._input(node, i, v)
        return node.outputs[0]

    def normalize(self, vector: bpy.types.NodeSocket) -> bpy.types.NodeSocket:
        node = self._node("ShaderNodeVectorMath")
        node.operation = "NORMALIZE"
        self.tree.links.new(vector, node.inputs[0])
        return node.outputs["Vector"]

    def dot(self, a: bpy.types.NodeSocket, b: bpy.types.NodeSocket) -> bpy.types.NodeSocket:
        node = self._node("ShaderNodeVectorMath")
        node.operation = "DOT_PRODUCT"
        self.tree.links.new(a, node.inputs[0])
        self.tree.links.new(b, node.inputs[1])
        return node.outputs["Value"]


def _divide(a: float, b: float) -> float:
    return a / b if b != 0.0 else 0.0  # the Math node's safe division


_OPS = {
    "ADD": lambda a, b: a + b,
    "SUBTRACT": lambda a, b: a - b,
    "MULTIPLY": lambda a, b: a * b,
    "DIVIDE": _divide,
    "ABSOLUTE": lambda a, b: abs(a),
    "MINIMUM": min,
    "MAXIMUM": max,
    "FLOOR": lambda a, b: float(math.floor(a)),
    "LESS_THAN": lambda a, b: 1.0 if a < b else 0.0,
    "GREATER_THAN": lambda a, b: 1.0 if a > b else 0.0,
}


class FloatMath(_Composites):
    """NodeMath's operations on floats (vectors: 3-tuples). Only the
    operations in _OPS exist: a new one in the shared math fails here first."""

    def math(self, op: str, a: float, b: float = 0.0, clamp: bool = False) -> float:
        r = float(_OPS[op](float(a), float(b)))
        return min(max(r, 0.0), 1.0) if clamp else r

    def separate(self, vector: Tuple[float, float, float]) -> Tuple[float, float, float]:
        return vector

    def combine(self, x: float, y: float, z: float = 0.0) -> Tuple[float, float, float]:
        return (float(x), float(y), float(z))

    def normalize(self, vector: Tuple[float, float, float]) -> Tuple[float, float, float]:
        x, y, z = vector
        length = math.sqrt(x * x + y * y + z * z)
        if length == 0.0:
            return (0.0, 0.0, 0.0)
        return (x / length, y / length, z / length)

    def dot(self, a: Tuple[float, float, float], b: Tuple[float, float, float]) -> float:
        return sum(p * q for p, q in zip(a, b))
