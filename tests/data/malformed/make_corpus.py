#!/usr/bin/env python3
"""Generate the malformed-input corpus used by tests/malformed_input.rs and tests/scene_load.rs.

Run from anywhere:  python3 tests/data/malformed/make_corpus.py
Stdlib only. Every case is a small hand-made scene with exactly ONE problem; the expected error
fragments live in tests/common/malformed_cases.rs.
"""

import base64
import json
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def f32s(values):
    return b"".join(struct.pack("<f", v) for v in values)


def u16s(values):
    data = b"".join(struct.pack("<H", v) for v in values)
    return data + b"\0" * (-len(data) % 4)


class Doc:
    """A minimal glTF: one buffer, meshes of (positions, indices) triangles, materials, nodes."""

    def __init__(self):
        self.bin = b""
        self.views = []
        self.accessors = []
        self.meshes = []
        self.materials = []
        self.nodes = []
        self.roots = []
        self.cameras = []
        self.ext_used = []

    def view(self, data):
        self.bin += b"\0" * (-len(self.bin) % 4)
        self.views.append({"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)})
        self.bin += data
        return len(self.views) - 1

    def tri_mesh(self, name, positions, indices, material=None):
        flat = [c for p in positions for c in p]
        pv = self.view(f32s(flat))
        self.accessors.append({
            "bufferView": pv, "componentType": 5126, "count": len(positions), "type": "VEC3",
            "min": [min(p[k] for p in positions) for k in range(3)],
            "max": [max(p[k] for p in positions) for k in range(3)],
        })
        pa = len(self.accessors) - 1
        iv = self.view(u16s(indices))
        self.accessors.append({"bufferView": iv, "componentType": 5123, "count": len(indices),
                               "type": "SCALAR"})
        prim = {"attributes": {"POSITION": pa}, "indices": len(self.accessors) - 1}
        if material is not None:
            prim["material"] = material
        self.meshes.append({"name": name, "primitives": [prim]})
        return len(self.meshes) - 1

    def material(self, name, emissive=0.0):
        m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0]}}
        if emissive:
            m["emissiveFactor"] = [1.0, 1.0, 1.0]
            m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": emissive}}
            if "KHR_materials_emissive_strength" not in self.ext_used:
                self.ext_used.append("KHR_materials_emissive_strength")
        self.materials.append(m)
        return len(self.materials) - 1

    def node(self, node, root=True):
        self.nodes.append(node)
        if root:
            self.roots.append(len(self.nodes) - 1)
        return len(self.nodes) - 1

    def camera(self):
        self.cameras.append({"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01}})
        return self.node({"name": "Camera", "camera": len(self.cameras) - 1,
                          "translation": [0.0, 0.0, 3.0]})

    def json(self, buffer_uri=None, glb=False):
        d = {"asset": {"version": "2.0", "generator": "prism tests/data/malformed/make_corpus.py"},
             "scene": 0, "scenes": [{"nodes": self.roots}], "nodes": self.nodes}
        for key, val in (("meshes", self.meshes), ("materials", self.materials),
                         ("cameras", self.cameras), ("accessors", self.accessors),
                         ("bufferViews", self.views)):
            if val:
                d[key] = val
        if self.ext_used:
            d["extensionsUsed"] = self.ext_used
        if self.views:
            buf = {"byteLength": len(self.bin)}
            if not glb:
                buf["uri"] = buffer_uri or (
                    "data:application/octet-stream;base64," + base64.b64encode(self.bin).decode())
            d["buffers"] = [buf]
        return d

    def glb(self):
        js = json.dumps(self.json(glb=True), separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        binc = self.bin + b"\0" * (-len(self.bin) % 4)
        total = 12 + 8 + len(js) + 8 + len(binc)
        return (b"glTF" + struct.pack("<II", 2, total) + struct.pack("<I", len(js)) + b"JSON" + js
                + struct.pack("<I", len(binc)) + b"BIN\0" + binc)


QUAD = [(-0.5, -0.5, 0.0), (0.5, -0.5, 0.0), (0.5, 0.5, 0.0), (-0.5, 0.5, 0.0)]
QUAD_IDX = [0, 1, 2, 0, 2, 3]


def good_scene():
    """Emissive quad 'Light' (material 'Emitter'), a quad with material 'Skin', a camera."""
    d = Doc()
    em = d.material("Emitter", emissive=5.0)
    skin = d.material("Skin")
    d.node({"name": "Light", "mesh": d.tri_mesh("Light", QUAD, QUAD_IDX, em),
            "translation": [0.0, 1.0, 0.0]})
    d.node({"name": "Skin", "mesh": d.tri_mesh("Skin", QUAD, QUAD_IDX, skin)})
    d.camera()
    return d


def write(name, data):
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(os.path.join(HERE, name), mode) as f:
        f.write(data)


def write_gltf(name, doc, **kw):
    write(name, json.dumps(doc.json(**kw), indent=1) + "\n")


def sidecar_case(stem, sidecar_text):
    write_gltf(stem + ".gltf", good_scene())
    write(stem + ".materials.json", sidecar_text)


def main():
    # Binary glTF cut in the middle of its BIN chunk.
    glb = good_scene().glb()
    write("truncated.glb", glb[: len(glb) // 2])

    # External buffer that does not exist.
    write_gltf("missing_buffer.gltf", good_scene(), buffer_uri="missing_buffer.bin")

    skin_ok = '"sigma_a": [0.032, 0.17, 0.48], "sigma_s": [0.74, 0.88, 1.01], "scale": 1000.0'
    sidecar_case("sidecar_syntax",
                 '{ "version": 1,\n  "materials": {\n    "Skin": { "subsurface": { "preset": "Skin1" } },\n  }\n}\n')
    sidecar_case("sidecar_nan",
                 '{ "version": 1,\n  "materials": {\n    "Skin": { "subsurface": { "sigma_a": [NaN, 0.17, 0.48], "sigma_s": [0.74, 0.88, 1.01] } }\n  }\n}\n')
    sidecar_case("sidecar_inf",
                 '{ "version": 1,\n  "materials": {\n    "Skin": { "subsurface": { "sigma_a": [0.032, 0.17, 0.48], "sigma_s": [0.74, 0.88, 1e300] } }\n  }\n}\n')
    sidecar_case("sidecar_negative",
                 '{ "version": 1,\n  "materials": {\n    "Skin": { "subsurface": { "sigma_a": [0.032, -0.17, 0.48], "sigma_s": [0.74, 0.88, 1.01] } }\n  }\n}\n')
    sidecar_case("sidecar_unknown_preset",
                 '{ "version": 1,\n  "materials": {\n    "Skin": { "subsurface": { "preset": "Jade" } }\n  }\n}\n')
    sidecar_case("sidecar_unknown_material",
                 '{ "version": 1,\n  "materials": {\n    "Marble": { "subsurface": { "preset": "Marble" } }\n  }\n}\n')
    sidecar_case("sidecar_unknown_key",
                 '{ "version": 1,\n  "materials": {\n    "Skin": { "subsurface": { %s, "sigma_t": [1, 1, 1] } }\n  }\n}\n' % skin_ok)
    sidecar_case("sidecar_version",
                 '{ "version": 2, "materials": {} }\n')

    # No camera node.
    d = Doc()
    em = d.material("Emitter", emissive=5.0)
    d.node({"name": "Light", "mesh": d.tri_mesh("Light", QUAD, QUAD_IDX, em)})
    write_gltf("no_camera.gltf", d)

    # Valid edge cases (tests/data/edge/, tests/edge_scenes.rs): they render, with a warning.
    # Only degenerate triangles: collinear points and a repeated index.
    d = Doc()
    em = d.material("Emitter", emissive=5.0)
    line = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.0), (0.0, 1.0, 0.0)]
    d.node({"name": "Flat", "mesh": d.tri_mesh("Flat", line, [0, 1, 2, 3, 3, 0], em)})
    d.camera()
    write_gltf("../edge/degenerate_only.gltf", d)

    # Geometry and a camera, but nothing emits (and no sidecar world).
    d = Doc()
    grey = d.material("Grey")
    d.node({"name": "Quad", "mesh": d.tri_mesh("Quad", QUAD, QUAD_IDX, grey)})
    d.camera()
    write_gltf("../edge/zero_lights.gltf", d)

    # Triangle index past the end of the vertex array.
    d = Doc()
    em = d.material("Emitter", emissive=5.0)
    d.node({"name": "Quad", "mesh": d.tri_mesh("Quad", QUAD, [0, 1, 2, 0, 2, 7], em)})
    d.camera()
    write_gltf("index_out_of_range.gltf", d)

    # Node 0 is its own grandchild.
    d = good_scene()
    d.nodes[0]["children"] = [1]
    d.nodes[1]["children"] = [0]
    d.roots = [0, 2]
    write_gltf("node_cycle.gltf", d)

    # An accessor reading past the end of its buffer view.
    d = good_scene()
    d.accessors[0]["count"] = 1000
    write_gltf("accessor_overrun.gltf", d)

    # Broken references that drawn geometry follows: each names its JSON path (the loader checks
    # what it uses, not the whole file; tests/data/lenient/ has the unused ones).
    d = good_scene()
    d.accessors[0]["bufferView"] = 9
    write_gltf("drawn_accessor_bad_view.gltf", d)

    d = good_scene()
    d.meshes[1]["primitives"][0]["material"] = 7
    write_gltf("drawn_material_out_of_range.gltf", d)

    d = good_scene()
    d.nodes[1]["mesh"] = 5
    write_gltf("node_mesh_out_of_range.gltf", d)

    d = good_scene()
    d.nodes[0]["children"] = [9]
    write_gltf("child_out_of_range.gltf", d)

    d = good_scene()
    d.accessors[0]["componentType"] = 5130  # GL_DOUBLE: not a glTF component type
    write_gltf("bad_component_type.gltf", d)

    d = good_scene()
    d.accessors[0]["count"] = 2.5
    write_gltf("fractional_count.gltf", d)

    d = good_scene()
    d.materials[1]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 4}
    write_gltf("drawn_material_bad_texture.gltf", d)

    d = good_scene()
    doc = d.json()
    doc["scene"] = 3
    write("scene_out_of_range.gltf", json.dumps(doc, indent=1) + "\n")

    # Compressed geometry that the renderer cannot decode, required by the file.
    d = good_scene()
    doc = d.json()
    doc["extensionsUsed"] = doc.get("extensionsUsed", []) + ["KHR_draco_mesh_compression"]
    doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    write("draco_required.gltf", json.dumps(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
