#!/usr/bin/env python3
"""Generate the lenient-loading corpus used by tests/lenient_gltf.rs.

Run from anywhere:  python3 tests/data/lenient/make_corpus.py
Stdlib only. Every case but one is a VALID glTF 2.0 file (the Khronos glTF-Validator 2.0.0-dev.3.10
reports 0 errors; in ktx2_texture.gltf only the absent texture.ktx2, which the renderer never
opens) in a form the `gltf` crate's own validation or JSON model refuses, or with parts the
renderer cannot use. unused_broken_parts.gltf is invalid on purpose, in parts that nothing drawn
uses: the loader refuses only what would draw wrong. Each must render (exit 0) with exactly the
warnings tests/lenient_gltf.rs expects.

The scenes share one layout: a camera at z = 3 looking down -z at a unit quad whose emission
(black world, no other light) is what the centre pixels show, so a pixel check tells whether
the right data was read.
"""

import base64
import json
import os
import struct
import sys
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "malformed"))
from make_corpus import Doc, QUAD, QUAD_IDX, f32s  # noqa: E402

# A 2x2 lossless WebP of the sRGB colour (51, 153, 255), written by the `image` crate's encoder.
WEBP_51_153_255 = base64.b64decode(
    "UklGRpYAAABXRUJQVlA4TIoAAAAvAUAAEM1VICICHogEAAAAAIABAAAAAAAAAAAAAAAAAAAAAAAABgAAAAAAAAAAAAAAAAQAAHggAQ"
    "AAAAAA5x8AAAAAAAAAAAAAAAAAAAAAAABAAAAAAAAAAAAAAAAA4IEEAAAAAACcfwAAAAAAAAAAAAAAABAAAAAAAAAAAAAAAAAAAAAA"
    "AABA5Ac=")


def png_1x1(rgb):
    """A 1x1 8-bit RGB PNG."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    ihdr = struct.pack(">IIBBBBB", 1, 1, 8, 2, 0, 0, 0)
    raw = b"\0" + bytes(rgb)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw))
            + chunk(b"IEND", b""))


def data_uri(mime, data):
    return "data:%s;base64,%s" % (mime, base64.b64encode(data).decode())


def emissive_quad(color=(1.0, 1.0, 1.0), strength=2.0, uvs=False):
    """The shared layout; returns (doc, material index). The quad's material emits
    `color * strength`."""
    d = Doc()
    m = d.material("Glow", emissive=strength)
    d.materials[m]["emissiveFactor"] = list(color)
    mesh = d.tri_mesh("Quad", QUAD, QUAD_IDX, m)
    if uvs:
        uv = d.view(f32s([0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0]))
        d.accessors.append({"bufferView": uv, "componentType": 5126, "count": 4, "type": "VEC2"})
        d.meshes[mesh]["primitives"][0]["attributes"]["TEXCOORD_0"] = len(d.accessors) - 1
    d.node({"name": "Quad", "mesh": mesh})
    d.camera()
    return d, m


def write_json(name, doc):
    with open(os.path.join(HERE, name), "w") as f:
        f.write(json.dumps(doc, indent=1) + "\n")


def floats_for_ints(v):
    """Every integer written as a float (3 -> 3.0)."""
    if isinstance(v, bool):
        return v
    if isinstance(v, int):
        return float(v)
    if isinstance(v, list):
        return [floats_for_ints(x) for x in v]
    if isinstance(v, dict):
        return {k: floats_for_ints(x) for k, x in v.items()}
    return v


def main():
    # Integers written as floats everywhere: indices, counts, component types, offsets.
    d, _ = emissive_quad()
    write_json("integers_as_floats.gltf", floats_for_ints(d.json()))

    # POSITION from a sparse-only accessor (zeros, then every vertex substituted) and NORMAL
    # from an accessor without bufferView or sparse: all zeros (glTF 2.0 spec 3.6.2.3).
    d, _ = emissive_quad()
    prim = d.meshes[0]["primitives"][0]
    pos = d.accessors[prim["attributes"]["POSITION"]]
    idx_view = d.view(bytes([0, 1, 2, 3]))
    val_view = d.view(f32s([c for p in QUAD for c in p]))
    sparse_pos = {"componentType": 5126, "count": 4, "type": "VEC3", "min": pos["min"],
                  "max": pos["max"],
                  "sparse": {"count": 4, "indices": {"bufferView": idx_view, "componentType": 5121},
                             "values": {"bufferView": val_view}}}
    d.accessors.append(sparse_pos)
    prim["attributes"]["POSITION"] = len(d.accessors) - 1
    d.accessors.append({"componentType": 5126, "count": 4, "type": "VEC3"})
    prim["attributes"]["NORMAL"] = len(d.accessors) - 1
    write_json("zero_and_sparse_accessors.gltf", d.json())

    # EXT_texture_webp with a PNG fallback of another colour: the WebP image is the one used.
    d, m = emissive_quad(uvs=True)
    doc = d.json()
    doc["images"] = [{"uri": data_uri("image/png", png_1x1((255, 0, 0)))},
                     {"uri": data_uri("image/webp", WEBP_51_153_255)}]
    doc["textures"] = [{"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}}]
    doc["materials"][m]["emissiveTexture"] = {"index": 0}
    doc["extensionsUsed"] = doc.get("extensionsUsed", []) + ["EXT_texture_webp"]
    write_json("webp_texture.gltf", doc)

    # A KTX2 (KHR_texture_basisu, required) texture without a core source: the slot falls back
    # to its factor, with a warning.
    d, m = emissive_quad(color=(0.5, 0.25, 1.0), uvs=True)
    doc = d.json()
    doc["images"] = [{"uri": "texture.ktx2", "mimeType": "image/ktx2"}]
    doc["textures"] = [{"extensions": {"KHR_texture_basisu": {"source": 0}}}]
    doc["materials"][m]["emissiveTexture"] = {"index": 0}
    doc["extensionsUsed"] = doc.get("extensionsUsed", []) + ["KHR_texture_basisu"]
    doc["extensionsRequired"] = ["KHR_texture_basisu"]
    write_json("ktx2_texture.gltf", doc)

    # KHR_materials_ior with ior 0 (allowed by the extension's schema: F0 = 1).
    d, m = emissive_quad()
    doc = d.json()
    doc["materials"][m]["extensions"]["KHR_materials_ior"] = {"ior": 0}
    doc["extensionsUsed"].append("KHR_materials_ior")
    write_json("ior_zero.gltf", doc)

    # A light type from a future revision of KHR_lights_punctual beside a known one.
    d, _ = emissive_quad()
    doc = d.json()
    doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "area_future", "intensity": 10.0},
        {"type": "point", "intensity": 100.0}]}}
    doc["extensionsUsed"].append("KHR_lights_punctual")
    for li in (0, 1):
        doc["nodes"].append({"name": "Lamp%d" % li, "translation": [0.0, 1.0, 2.0],
                             "extensions": {"KHR_lights_punctual": {"light": li}}})
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    write_json("unknown_light_type.gltf", doc)

    # KHR_animation_pointer: an animation channel targets a material property, not a node.
    d, _ = emissive_quad()
    t = d.view(f32s([0.0, 1.0]))
    d.accessors.append({"bufferView": t, "componentType": 5126, "count": 2, "type": "SCALAR",
                        "min": [0.0], "max": [1.0]})
    v = d.view(f32s([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]))
    d.accessors.append({"bufferView": v, "componentType": 5126, "count": 2, "type": "VEC3"})
    doc = d.json()
    doc["animations"] = [{
        "samplers": [{"input": len(d.accessors) - 2, "output": len(d.accessors) - 1}],
        "channels": [{"sampler": 0, "target": {"path": "pointer", "extensions": {
            "KHR_animation_pointer": {"pointer": "/materials/0/emissiveFactor"}}}}]}]
    doc["extensionsUsed"].append("KHR_animation_pointer")
    write_json("animation_pointer.gltf", doc)

    # Parts nothing drawn uses, each broken: an accessor whose buffer view does not exist, a
    # buffer whose file is missing, one without uri (an EXT_meshopt_compression fallback
    # buffer has none), a material whose texture does not exist, an image without a source.
    d, _ = emissive_quad()
    d.accessors.append({"bufferView": 42, "componentType": 5126, "count": 3, "type": "VEC3"})
    d.materials.append({"name": "Unused", "pbrMetallicRoughness": {"baseColorTexture": {"index": 9}}})
    doc = d.json()
    doc["buffers"].append({"uri": "missing.bin", "byteLength": 64})
    doc["buffers"].append({"byteLength": 64})
    doc["bufferViews"].append({"buffer": 1, "byteLength": 64})
    doc["images"] = [{"name": "NoSource"}]
    write_json("unused_broken_parts.gltf", doc)

    # A primitive without POSITION (the spec: clients SHOULD skip it) beside the quad.
    d, m = emissive_quad()
    n = d.view(f32s([0.0, 0.0, 1.0] * 3))
    d.accessors.append({"bufferView": n, "componentType": 5126, "count": 3, "type": "VEC3"})
    d.meshes[0]["primitives"].append({"attributes": {"NORMAL": len(d.accessors) - 1},
                                      "material": m})
    write_json("primitive_without_position.gltf", d.json())

    # Morph targets with the mesh's default weights: the base shape is a quad a hundredth of
    # the size, the weighted target (0.5 x twice the difference) brings it to full size.
    d, _ = emissive_quad()
    prim = d.meshes[0]["primitives"][0]
    small = [(0.01 * x, 0.01 * y, z) for (x, y, z) in QUAD]
    base = d.view(f32s([c for p in small for c in p]))
    d.accessors.append({"bufferView": base, "componentType": 5126, "count": 4, "type": "VEC3",
                        "min": [-0.005, -0.005, 0.0], "max": [0.005, 0.005, 0.0]})
    prim["attributes"]["POSITION"] = len(d.accessors) - 1
    delta = [(2.0 * (p[0] - q[0]), 2.0 * (p[1] - q[1]), 0.0) for p, q in zip(QUAD, small)]
    dv = d.view(f32s([c for p in delta for c in p]))
    d.accessors.append({"bufferView": dv, "componentType": 5126, "count": 4, "type": "VEC3",
                        "min": [-0.99, -0.99, 0.0], "max": [0.99, 0.99, 0.0]})
    prim["targets"] = [{"POSITION": len(d.accessors) - 1}]
    d.meshes[0]["weights"] = [0.5]
    write_json("morph_targets.gltf", d.json())

    # EXT_mesh_gpu_instancing (required): two half-size copies left and right of the centre,
    # which stays dark; the node's own transform applies after the instances'.
    d, _ = emissive_quad()
    tv = d.view(f32s([-0.8, 0.0, 0.0, 0.8, 0.0, 0.0]))
    d.accessors.append({"bufferView": tv, "componentType": 5126, "count": 2, "type": "VEC3"})
    sv = d.view(f32s([0.5, 0.5, 0.5] * 2))
    d.accessors.append({"bufferView": sv, "componentType": 5126, "count": 2, "type": "VEC3"})
    d.nodes[0]["extensions"] = {"EXT_mesh_gpu_instancing": {"attributes": {
        "TRANSLATION": len(d.accessors) - 2, "SCALE": len(d.accessors) - 1}}}
    doc = d.json()
    doc["extensionsUsed"].append("EXT_mesh_gpu_instancing")
    doc["extensionsRequired"] = ["EXT_mesh_gpu_instancing"]
    write_json("gpu_instancing.gltf", doc)

    # An extension the renderer does not know, required: a warning, not a refusal (only
    # required geometry compression, which cannot be read at all, is refused).
    d, _ = emissive_quad()
    doc = d.json()
    doc["extensionsUsed"].append("EXT_future_material")
    doc["extensionsRequired"] = ["EXT_future_material"]
    write_json("unknown_required_extension.gltf", doc)


if __name__ == "__main__":
    main()
