#!/usr/bin/env python3
"""Write the Prism Cornell box test scene as a single-file glTF 2.0.

Outputs (next to this script):
  cornell/cornell.gltf            glTF 2.0 JSON, binary buffer embedded as a base64 data URI
  cornell/cornell.materials.json  Prism sidecar (no material overrides, black world, render settings)

Stdlib only; the output is deterministic (same bytes on every run).

Conventions: 1 unit = 1 m, Y up, camera looks down -Z. The box spans
x in [-1, 1], y in [0, 2], z in [-1, 1] and is open at +z (camera side).

Scene graph (root nodes):
  Room         mesh "Room", 3 primitives: White (floor, ceiling, back wall), Red (left x=-1), Green (right x=+1)
  Light        mesh "Light": 0.5 x 0.4 m quad at y=1.98 facing -y, material "Light"
               (emissiveFactor [1,1,1] x KHR_materials_emissive_strength 15)
  Objects      translation (0,0,-0.1), rotation 5 deg about +Y
    TallBox    translation (-0.35,0.6,-0.2), rotation 10 deg about +Y -> 15 deg in world;
               mesh is a 0.6 x 1.2 x 0.6 box centred on its origin, so it stands on the floor
  MetalSphere  translation (0.5,0.3,-0.3), mesh "MetalSphere" (r = 0.3, material Metal)
  GlassSphere  translation (-0.2,0.3,0.45), mesh "GlassSphere" (r = 0.3, material Glass)
               both sphere meshes share the same accessors (one geometry, two materials)
  Camera       perspective, yfov 0.6911 rad, aspect 1, at (0,1,3.9) looking down -Z

Every primitive has POSITION (with min/max), NORMAL, TEXCOORD_0 and uint32 indices;
triangles are counter-clockwise seen from the side their normals point to.
"""

import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
OUT_DIR = os.path.join(HERE, "cornell")

# glTF constants
FLOAT = 5126
UINT = 5125
ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963


class Builder:
    def __init__(self):
        self.blob = bytearray()
        self.buffer_views = []
        self.accessors = []

    def _view(self, data, target):
        while len(self.blob) % 4:
            self.blob.append(0)
        offset = len(self.blob)
        self.blob += data
        self.buffer_views.append(
            {"buffer": 0, "byteOffset": offset, "byteLength": len(data), "target": target}
        )
        return len(self.buffer_views) - 1

    def vec(self, rows, kind, with_bounds=False):
        n = len(rows[0])
        data = b"".join(struct.pack("<%df" % n, *r) for r in rows)
        acc = {
            "bufferView": self._view(data, ARRAY_BUFFER),
            "componentType": FLOAT,
            "count": len(rows),
            "type": kind,
        }
        if with_bounds:
            # bounds of the float32 values actually stored
            f32 = [struct.unpack("<%df" % n, struct.pack("<%df" % n, *r)) for r in rows]
            acc["min"] = [min(r[i] for r in f32) for i in range(n)]
            acc["max"] = [max(r[i] for r in f32) for i in range(n)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def indices(self, idx):
        data = struct.pack("<%dI" % len(idx), *idx)
        self.accessors.append(
            {
                "bufferView": self._view(data, ELEMENT_ARRAY_BUFFER),
                "componentType": UINT,
                "count": len(idx),
                "type": "SCALAR",
            }
        )
        return len(self.accessors) - 1

    def geometry(self, geo):
        """geo = (positions, normals, uvs, indices) -> attributes dict and index accessor."""
        pos, nrm, uv, idx = geo
        check_winding(pos, nrm, idx)
        attrs = {
            "POSITION": self.vec(pos, "VEC3", with_bounds=True),
            "NORMAL": self.vec(nrm, "VEC3"),
            "TEXCOORD_0": self.vec(uv, "VEC2"),
        }
        return attrs, self.indices(idx)


# ---------------------------------------------------------------- geometry


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def check_winding(pos, nrm, idx):
    """Every triangle must be CCW seen from the side its vertex normals point to."""
    for t in range(0, len(idx), 3):
        a, b, c = idx[t : t + 3]
        g = cross(sub(pos[b], pos[a]), sub(pos[c], pos[a]))
        n = tuple(nrm[a][k] + nrm[b][k] + nrm[c][k] for k in range(3))
        assert dot(g, g) > 1e-20, "degenerate triangle %d" % (t // 3)
        assert dot(g, n) > 0, "triangle %d wound against its normals" % (t // 3)


class Geo:
    def __init__(self):
        self.pos, self.nrm, self.uv, self.idx = [], [], [], []

    def quad(self, origin, edge_u, edge_v):
        """Quad origin + s*edge_u + t*edge_v, s,t in [0,1]; normal = normalize(edge_u x edge_v)."""
        n = cross(edge_u, edge_v)
        ln = math.sqrt(dot(n, n))
        n = (n[0] / ln + 0.0, n[1] / ln + 0.0, n[2] / ln + 0.0)  # + 0.0 drops -0.0
        base = len(self.pos)
        for s, t in ((0, 0), (1, 0), (1, 1), (0, 1)):
            self.pos.append(tuple(origin[k] + s * edge_u[k] + t * edge_v[k] for k in range(3)))
            self.nrm.append(n)
            self.uv.append((float(s), float(1 - t)))
        self.idx += [base, base + 1, base + 2, base, base + 2, base + 3]
        return self

    def tup(self):
        return self.pos, self.nrm, self.uv, self.idx


def box_geo(hx, hy, hz):
    """Axis-aligned box centred on the origin, outward normals, 4 vertices per face."""
    g = Geo()
    g.quad((hx, -hy, hz), (0, 0, -2 * hz), (0, 2 * hy, 0))  # +x
    g.quad((-hx, -hy, -hz), (0, 0, 2 * hz), (0, 2 * hy, 0))  # -x
    g.quad((-hx, hy, hz), (2 * hx, 0, 0), (0, 0, -2 * hz))  # +y
    g.quad((-hx, -hy, -hz), (2 * hx, 0, 0), (0, 0, 2 * hz))  # -y
    g.quad((-hx, -hy, hz), (2 * hx, 0, 0), (0, 2 * hy, 0))  # +z
    g.quad((hx, -hy, -hz), (-2 * hx, 0, 0), (0, 2 * hy, 0))  # -z
    return g.tup()


def uv_sphere_geo(radius, segments=48, rings=24):
    """UV sphere with smooth per-vertex normals; seam and pole vertices duplicated for UVs."""
    pos, nrm, uv, idx = [], [], [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings  # 0 at +Y pole
        st, ct = math.sin(theta), math.cos(theta)
        if i in (0, rings):
            st = 0.0  # exact poles
        for j in range(segments + 1):
            phi = 2.0 * math.pi * (j % segments) / segments
            n = (st * math.sin(phi), ct, st * math.cos(phi))
            pos.append((radius * n[0], radius * n[1], radius * n[2]))
            nrm.append(n)
            uv.append((j / segments, i / rings))
    row = segments + 1
    for i in range(rings):
        for j in range(segments):
            a = i * row + j  # upper-left
            b = a + 1  # upper-right
            c = a + row  # lower-left
            d = c + 1  # lower-right
            if i != 0:
                idx += [a, c, b]
            if i != rings - 1:
                idx += [b, c, d]
    return pos, nrm, uv, idx


def rot_y(deg):
    h = math.radians(deg) / 2.0
    return [0.0, math.sin(h), 0.0, math.cos(h)]


# ---------------------------------------------------------------- scene


def diffuse(name, rgb):
    return {
        "name": name,
        "pbrMetallicRoughness": {
            "baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        },
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}},
    }


def build():
    b = Builder()

    materials = [
        diffuse("White", (0.73, 0.73, 0.73)),  # 0
        diffuse("Red", (0.63, 0.065, 0.05)),  # 1
        diffuse("Green", (0.14, 0.45, 0.091)),  # 2
        {  # 3: pure emitter, black diffuse base
            "name": "Light",
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.0, 0.0, 0.0, 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
            "emissiveFactor": [1.0, 1.0, 1.0],
            "extensions": {
                "KHR_materials_emissive_strength": {"emissiveStrength": 15.0},
                "KHR_materials_specular": {"specularFactor": 0.0},
            },
        },
        {  # 4
            "name": "Metal",
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.95, 0.64, 0.54, 1.0],
                "metallicFactor": 1.0,
                "roughnessFactor": 0.2,
            },
        },
        {  # 5
            "name": "Glass",
            "pbrMetallicRoughness": {
                "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 0.0,
            },
            "extensions": {
                "KHR_materials_transmission": {"transmissionFactor": 1.0},
                "KHR_materials_ior": {"ior": 1.5},
            },
        },
    ]
    WHITE, RED, GREEN, LIGHT, METAL, GLASS = range(6)

    # Room: normals point into the box.
    white = Geo()
    white.quad((-1, 0, 1), (2, 0, 0), (0, 0, -2))  # floor y=0, +y
    white.quad((-1, 2, -1), (2, 0, 0), (0, 0, 2))  # ceiling y=2, -y
    white.quad((-1, 0, -1), (2, 0, 0), (0, 2, 0))  # back z=-1, +z
    red = Geo().quad((-1, 0, 1), (0, 0, -2), (0, 2, 0))  # left x=-1, +x
    green = Geo().quad((1, 0, -1), (0, 0, 2), (0, 2, 0))  # right x=+1, -x

    def prim(geo, material):
        attrs, ind = b.geometry(geo.tup() if isinstance(geo, Geo) else geo)
        return {"attributes": attrs, "indices": ind, "material": material, "mode": 4}

    light = Geo().quad((-0.25, 1.98, -0.2), (0.5, 0, 0), (0, 0, 0.4))  # normal -y
    assert light.nrm[0] == (0.0, -1.0, 0.0)

    sphere_attrs, sphere_ind = b.geometry(uv_sphere_geo(0.3))

    def sphere_prim(material):
        return {"attributes": dict(sphere_attrs), "indices": sphere_ind, "material": material, "mode": 4}

    meshes = [
        {"name": "Room", "primitives": [prim(white, WHITE), prim(red, RED), prim(green, GREEN)]},  # 0
        {"name": "Light", "primitives": [prim(light, LIGHT)]},  # 1
        {"name": "TallBox", "primitives": [prim(box_geo(0.3, 0.6, 0.3), WHITE)]},  # 2
        {"name": "MetalSphere", "primitives": [sphere_prim(METAL)]},  # 3
        {"name": "GlassSphere", "primitives": [sphere_prim(GLASS)]},  # 4
    ]

    nodes = [
        {"name": "Room", "mesh": 0},  # 0
        {"name": "Light", "mesh": 1},  # 1
        {"name": "Objects", "children": [3], "translation": [0.0, 0.0, -0.1], "rotation": rot_y(5.0)},  # 2
        {"name": "TallBox", "mesh": 2, "translation": [-0.35, 0.6, -0.2], "rotation": rot_y(10.0)},  # 3
        {"name": "MetalSphere", "mesh": 3, "translation": [0.5, 0.3, -0.3]},  # 4
        {"name": "GlassSphere", "mesh": 4, "translation": [-0.2, 0.3, 0.45]},  # 5
        {"name": "Camera", "camera": 0, "translation": [0.0, 1.0, 3.9]},  # 6 (default view: -Z, +Y up)
    ]

    gltf = {
        "asset": {"version": "2.0", "generator": "Prism scenes/make_cornell.py"},
        "extensionsUsed": [
            "KHR_materials_emissive_strength",
            "KHR_materials_ior",
            "KHR_materials_specular",
            "KHR_materials_transmission",
        ],
        "scene": 0,
        "scenes": [{"name": "Cornell", "nodes": [0, 1, 2, 4, 5, 6]}],
        "nodes": nodes,
        "cameras": [
            {
                "name": "Camera",
                "type": "perspective",
                "perspective": {"yfov": 0.6911, "aspectRatio": 1.0, "znear": 0.01, "zfar": 100.0},
            }
        ],
        "meshes": meshes,
        "materials": materials,
        "accessors": b.accessors,
        "bufferViews": b.buffer_views,
        "buffers": [
            {
                "byteLength": len(b.blob),
                "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(b.blob)).decode("ascii"),
            }
        ],
    }
    return gltf


SIDECAR = {
    "version": 1,
    "materials": {},
    "world": {"color": [0, 0, 0], "strength": 0},
    "render": {"spp": 64, "width": 256, "height": 256, "max_depth": 16},
}


def main():
    os.makedirs(OUT_DIR, exist_ok=True)
    gltf = build()
    path = os.path.join(OUT_DIR, "cornell.gltf")
    with open(path, "w", newline="\n") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")
    side = os.path.join(OUT_DIR, "cornell.materials.json")
    with open(side, "w", newline="\n") as f:
        json.dump(SIDECAR, f)
        f.write("\n")
    print("wrote %s (%d bytes of buffer)" % (path, gltf["buffers"][0]["byteLength"]))
    print("wrote %s" % side)


if __name__ == "__main__":
    main()
